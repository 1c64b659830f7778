#include "fold/fold.h"

namespace rayfold::core {

const char* fold_name(FoldMode m) {
  switch (m) {
    case FoldMode::none: return "none";
    case FoldMode::y: return "y";
    case FoldMode::x: return "x";
    case FoldMode::xy: return "xy";
  }
  return "?";
}

Aabb mirror_box(const Aabb& b, int group) {
  Aabb m = b;
  if (group_mirrors_x(group)) {
    m.lo.x = -b.hi.x;
    m.hi.x = -b.lo.x;
  }
  if (group_mirrors_y(group)) {
    m.lo.y = -b.hi.y;
    m.hi.y = -b.lo.y;
  }
  return m;
}

void mirror_columns(float rows[12], int group) {
  for (int r = 0; r < 3; ++r) {
    if (group_mirrors_x(group)) rows[4 * r + 0] = -rows[4 * r + 0];
    if (group_mirrors_y(group)) rows[4 * r + 1] = -rows[4 * r + 1];
  }
}

}  // namespace rayfold::core
