#include "fold/depth_xform.h"

#include <cmath>

namespace rayfold::core {
namespace {

// x as hi + lo, each the nearest float: 48 of the double's bits.
void split(const glm::dvec3& x, float* out) {
  for (int k = 0; k < 3; ++k) {
    const float hi = static_cast<float>(x[k]);
    out[k] = hi;
    out[3 + k] = static_cast<float>(x[k] - static_cast<double>(hi));
  }
}

}  // namespace

rf_depth_xform make_depth_xform(const Xform& space_from_trace, const Camera& camera, int trace_exponent) {
  // The trace-space ray of the pixel with offsets (ix, iy) (camera.h,
  // exact_direction and exact_origin): perspective from the eye along
  // (sx (ix + fx), sy (iy + fy), -1); orthographic from
  // (sx (ix + fx), sy (iy + fy), 0) / 2^e along (0, 0, -1).
  const bool ortho = camera.params.ortho != 0;
  const double unit = ortho ? std::ldexp(1.0, -trace_exponent) : 1.0;
  const glm::dvec3 a(camera.scale_x * unit, 0.0, 0.0);
  const glm::dvec3 b(0.0, camera.scale_y * unit, 0.0);
  const glm::dvec3 centre(camera.scale_x * camera.frac_x * unit, camera.scale_y * camera.frac_y * unit, 0.0);
  const glm::dvec3 c = ortho ? glm::dvec3(0.0, 0.0, -1.0) : centre + glm::dvec3(0.0, 0.0, -1.0);
  const glm::dvec3 o = ortho ? centre : glm::dvec3(0.0);
  const glm::dmat3 linear(space_from_trace);
  rf_depth_xform out{};
  split(linear * a, out.m);
  split(linear * b, out.m + 6);
  split(linear * c, out.m + 12);
  split(glm::dvec3(space_from_trace * glm::dvec4(o, 1.0)), out.m + 18);
  return out;
}

}  // namespace rayfold::core
