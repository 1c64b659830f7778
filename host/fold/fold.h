// Fold modes of affine-transformed ray alignment. In camera space a mirror is
// a sign flip of one coordinate, exact in IEEE floats:
//   y  mirrors about the camera's vertical plane (negates x): column x pairs
//      with xpair - x, the left half is traced, group 1 holds the mirrored
//      instances;
//   x  mirrors about the horizontal plane (negates y): row y pairs with
//      ypair - y, the top half is traced, group 2;
//   xy both: the top-left quadrant is traced, groups 1, 2 and 3 (both flips).
#pragma once

#include "scene/aabb.h"

namespace rayfold::core {

enum class FoldMode { none, y, x, xy };

inline bool folds_columns(FoldMode m) { return m == FoldMode::y || m == FoldMode::xy; }
inline bool folds_rows(FoldMode m) { return m == FoldMode::x || m == FoldMode::xy; }

// The fold with the axes that cannot pair dropped: a camera whose principal
// point is off the half-pixel grid in x cannot pair columns (y), in y rows.
inline FoldMode restrict_fold(FoldMode m, bool columns_ok, bool rows_ok) {
  const bool cols = folds_columns(m) && columns_ok, rows = folds_rows(m) && rows_ok;
  return cols && rows ? FoldMode::xy : cols ? FoldMode::y : rows ? FoldMode::x : FoldMode::none;
}

// "none", "y", "x" or "xy".
const char* fold_name(FoldMode m);

// Transform group g mirrors camera x when bit 0 is set, camera y for bit 1.
inline bool group_mirrors_x(int g) { return (g & 1) != 0; }
inline bool group_mirrors_y(int g) { return (g & 2) != 0; }

// A camera-space (or trace-space) box as group g's mirror sees it: x and/or
// y negated, ends swapped. Exact in floats.
Aabb mirror_box(const Aabb& b, int group);

// tree_from_trace (row-major 3x4) of group g's mirrored copy: the original
// times the mirror, i.e. the x and/or y column negated. A traced ray then
// reaches tree space bit-identical to the partner pixel's ray through the
// original.
void mirror_columns(float rows[12], int group);

}  // namespace rayfold::core
