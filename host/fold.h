// Fold modes of affine-transformed ray alignment. In camera space a mirror is
// a sign flip of one coordinate, exact in IEEE floats:
//   y  mirrors about the camera's vertical plane (negates x): column x pairs
//      with xpair - x, the left half is traced, group 1 holds the mirrored
//      instances;
//   x  mirrors about the horizontal plane (negates y): row y pairs with
//      ypair - y, the top half is traced, group 2;
//   xy both: the top-left quadrant is traced, groups 1, 2 and 3 (both flips).
#pragma once

#include <string>

namespace rayfold {

enum class FoldMode { none, y, x, xy };

inline bool folds_columns(FoldMode m) { return m == FoldMode::y || m == FoldMode::xy; }
inline bool folds_rows(FoldMode m) { return m == FoldMode::x || m == FoldMode::xy; }

const char* fold_name(FoldMode m);
// Throws UsageError for anything but none, y, x, xy.
FoldMode parse_fold(const std::string& text);

// Transform group g mirrors camera x when bit 0 is set, camera y for bit 1.
inline bool group_mirrors_x(int g) { return (g & 1) != 0; }
inline bool group_mirrors_y(int g) { return (g & 2) != 0; }

}  // namespace rayfold
