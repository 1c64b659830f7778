// Instance culling before the top-level build: drop instances that no traced
// ray can reach. Conservative by construction (a margin on every plane): a
// culled instance can never hold a hit, which the parity tests check against
// renders without culling.
#pragma once

#include "device_layout.h"
#include "scene/aabb.h"

namespace rayfold::core {

// The traced region of the image in the ray generator's integer coordinates
// (kx = 2x + kx0, ky = ky0 - 2y), inclusive.
struct TracedRegion {
  int kx_min = 0, kx_max = 0, ky_min = 0, ky_max = 0;
};

// Planes through the eye bounding every ray of a region (orthographic:
// parallel to the view axis, through the region's edges), plus the plane
// z = 0 behind which no ray (t > 0, dz = -1) goes. In the space the camera's
// rays are generated in (trace space, frame_camera).
class Frustum {
 public:
  Frustum(const rf_camera& cam, const TracedRegion& region);
  // False only when the camera-space box lies wholly outside.
  bool may_see(const Aabb& camera_box) const;

 private:
  double planes_[5][4];  // a x + b y + c z + d >= 0 inside
};

}  // namespace rayfold::core
