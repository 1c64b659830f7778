#include "fold/culling.h"

#include <algorithm>
#include <cmath>

namespace rayfold::core {

Frustum::Frustum(const rf_camera& cam, const TracedRegion& region) {
  // A ray is t * (sx * (kx + fx), sy * (ky + fy), -1); a point p in front
  // (p.z < 0) lies in the region when sx * (kx_min + fx) <= p.x / -p.z <=
  // sx * (kx_max + fx), and so on.
  const double x_lo = static_cast<double>(cam.scale_x) * (region.kx_min + static_cast<double>(cam.frac_x));
  const double x_hi = static_cast<double>(cam.scale_x) * (region.kx_max + static_cast<double>(cam.frac_x));
  const double y_lo = static_cast<double>(cam.scale_y) * (region.ky_min + static_cast<double>(cam.frac_y));
  const double y_hi = static_cast<double>(cam.scale_y) * (region.ky_max + static_cast<double>(cam.frac_y));
  // Orthographic: x_lo <= p.x <= x_hi and so on.
  const double persp[5][4] = {{1.0, 0.0, x_lo, 0.0},
                              {-1.0, 0.0, -x_hi, 0.0},
                              {0.0, 1.0, y_lo, 0.0},
                              {0.0, -1.0, -y_hi, 0.0},
                              {0.0, 0.0, -1.0, 0.0}};
  const double ortho[5][4] = {{1.0, 0.0, 0.0, -x_lo},
                              {-1.0, 0.0, 0.0, x_hi},
                              {0.0, 1.0, 0.0, -y_lo},
                              {0.0, -1.0, 0.0, y_hi},
                              {0.0, 0.0, -1.0, 0.0}};
  const double(*p)[4] = cam.ortho ? ortho : persp;
  std::copy(&p[0][0], &p[0][0] + 20, &planes_[0][0]);
}

bool Frustum::may_see(const Aabb& b) const {
  if (b.empty()) return false;
  double size = 0.0;
  for (int k = 0; k < 3; ++k) size = std::max({size, std::fabs(double(b.lo[k])), std::fabs(double(b.hi[k]))});
  for (const auto& n : planes_) {
    // Largest value of n . p over the box; the box is outside when even that
    // is clearly negative. The margin covers the float rounding of the rays.
    double best = n[3], norm = 0.0;
    for (int k = 0; k < 3; ++k) {
      best += std::max(n[k] * b.lo[k], n[k] * b.hi[k]);
      norm += std::fabs(n[k]);
    }
    if (best < -0x1p-16 * (size * norm + std::fabs(n[3]))) return false;
  }
  return true;
}

}  // namespace rayfold::core
