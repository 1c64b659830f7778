#include "fold/fold.h"

namespace rayfold::core {

Aabb mirror_box(const Aabb& b, int mirror) {
  Aabb m = b;
  if (mirror_negates_x(mirror)) {
    m.lo.x = -b.hi.x;
    m.hi.x = -b.lo.x;
  }
  if (mirror_negates_y(mirror)) {
    m.lo.y = -b.hi.y;
    m.hi.y = -b.lo.y;
  }
  return m;
}

void mirror_columns(float rows[12], int mirror) {
  for (int r = 0; r < 3; ++r) {
    if (mirror_negates_x(mirror)) rows[4 * r + 0] = -rows[4 * r + 0];
    if (mirror_negates_y(mirror)) rows[4 * r + 1] = -rows[4 * r + 1];
  }
}

}  // namespace rayfold::core
