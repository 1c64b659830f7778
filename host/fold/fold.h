// Fold modes of affine-transformed ray alignment. In camera space a mirror is
// a sign flip of one coordinate, exact in IEEE floats:
//   y  mirrors about the camera's vertical plane (negates x): column x pairs
//      with xpair - x, the left half is traced, mirror 1 holds the mirrored
//      instances;
//   x  mirrors about the horizontal plane (negates y): row y pairs with
//      ypair - y, the top half is traced, mirror 2;
//   xy both: the top-left quadrant is traced, mirrors 1, 2 and 3 (both flips).
#pragma once

#include <cstdint>

#include "rayfold/gbuffer.h"
#include "scene/aabb.h"

namespace rayfold::core {

// The fold is the public rayfold::Fold (rayfold/gbuffer.h), one type from the
// command line to the kernels' ray lists.

inline bool folds_columns(Fold m) { return m == Fold::y || m == Fold::xy; }
inline bool folds_rows(Fold m) { return m == Fold::x || m == Fold::xy; }

// The fold with the axes that cannot pair dropped: a camera whose principal
// point is off the half-pixel grid in x cannot pair columns (y), in y rows.
inline Fold restrict_fold(Fold m, bool columns_ok, bool rows_ok) {
  const bool cols = folds_columns(m) && columns_ok, rows = folds_rows(m) && rows_ok;
  return cols && rows ? Fold::xy : cols ? Fold::y : rows ? Fold::x : Fold::none;
}

// "none", "y", "x" or "xy" (the public rayfold::fold_name).
using rayfold::fold_name;

// The mirrors a fold traces, as slots of each view's transform groups
// (kernels/rf_types.h): none {0}, y {0, 1}, x {0, 2}, xy {0, 1, 2, 3}.
inline int mirror_slots(Fold m) { return m == Fold::none ? 1 : m == Fold::xy ? 4 : 2; }
inline int slot_mirror(Fold m, int slot) { return m == Fold::x && slot == 1 ? 2 : slot; }
// rf_camera::group_shift and slot_mirrors for the fold.
inline uint32_t fold_group_shift(Fold m) { return m == Fold::none ? 0u : m == Fold::xy ? 2u : 1u; }
inline uint32_t fold_slot_mirrors(Fold m) {
  uint32_t bits = 0;
  for (int s = 0; s < mirror_slots(m); ++s) bits |= static_cast<uint32_t>(slot_mirror(m, s)) << (2 * s);
  return bits;
}

// Mirror m negates camera x when bit 0 is set, camera y for bit 1.
inline bool mirror_negates_x(int m) { return (m & 1) != 0; }
inline bool mirror_negates_y(int m) { return (m & 2) != 0; }

// A camera-space (or trace-space) box as mirror m sees it: x and/or y
// negated, ends swapped. Exact in floats.
Aabb mirror_box(const Aabb& b, int mirror);

// tree_from_trace (row-major 3x4) of mirror m's copy: the original times
// the mirror, i.e. the x and/or y column negated. A traced ray then reaches
// tree space bit-identical to the partner pixel's ray through the original.
void mirror_columns(float rows[12], int mirror);

}  // namespace rayfold::core
