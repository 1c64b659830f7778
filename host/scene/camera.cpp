#include "scene/camera.h"

#include <cmath>
#include <sstream>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_inverse.hpp>

#include "util/errors.h"

namespace rayfold {

Camera make_camera(const CameraSpec& spec, int width, int height, double shift_x, double shift_y) {
  if (width <= 0 || height <= 0 || width > RF_MAX_IMAGE_SIDE || height > RF_MAX_IMAGE_SIDE) {
    std::ostringstream s;
    s << "image size " << width << "x" << height << " is out of range (1.." << RF_MAX_IMAGE_SIDE << " per side)";
    throw InputError("", s.str());
  }
  if (!(std::fabs(shift_x) <= 100.0 && std::fabs(shift_y) <= 100.0))
    throw InputError("",
                     "lens shift must be finite and at most 100 half-images (ray coordinates must stay exact floats)");
  if (!(spec.vfov_degrees > 0.0 && spec.vfov_degrees < 180.0))
    throw InputError("", "vertical field of view must be in (0, 180) degrees");
  const glm::dvec3 forward = spec.look_at - spec.eye;
  const double flen = glm::length(forward);
  if (!(flen > 0.0) || !std::isfinite(flen)) throw InputError("", "eye and look-at must be distinct finite points");
  for (int k = 0; k < 3; ++k)
    if (!(std::fabs(spec.eye[k]) <= kMaxWorldCoordinate && std::fabs(spec.look_at[k]) <= kMaxWorldCoordinate))
      throw InputError("", "eye and look-at must lie within world coordinates of +-8.5e37 (2^126)");
  const glm::dvec3 w = -forward / flen;  // camera +z points backwards
  const glm::dvec3 side = glm::cross(spec.up, w);
  const double slen = glm::length(side);
  if (!(slen > 1e-9 * glm::length(spec.up)) || !std::isfinite(slen))
    throw InputError("", "up vector must not be zero or parallel to the view direction");
  const glm::dvec3 u = side / slen;
  const glm::dvec3 v = glm::cross(w, u);

  Camera cam;
  cam.width = width;
  cam.height = height;
  cam.vfov_degrees = spec.vfov_degrees;
  cam.world_from_camera = Xform(glm::dvec4(u, 0.0), glm::dvec4(v, 0.0), glm::dvec4(w, 0.0), glm::dvec4(spec.eye, 1.0));
  cam.camera_from_world = glm::affineInverse(cam.world_from_camera);
  // Square pixels: pixel column x sits at (2x + kx0) / H * tan(vfov / 2),
  // in units of half a pixel from the optical axis.
  const float scale = static_cast<float>(std::tan(spec.vfov_degrees * M_PI / 360.0) / height);
  cam.params.scale_x = scale;
  cam.params.scale_y = scale;
  cam.params.kx0 = 1 - width + static_cast<int>(std::lround(shift_x * width));
  cam.params.ky0 = height - 1 + static_cast<int>(std::lround(shift_y * height));
  cam.params.width = width;
  cam.params.height = height;
  // The partner of column x has coordinate -(2x + kx0), i.e. column -kx0 - x.
  cam.params.xpair = -cam.params.kx0;
  cam.params.ypair = cam.params.ky0;
  cam.params.depth_scale = 1.0f;  // a frame sets its trace space's (frame.h)
  return cam;
}

double pixel_angle(const Camera& camera) { return 2.0 * static_cast<double>(camera.params.scale_x); }

CameraSpec frame_bounds(const Aabb& b, double vfov_degrees) {
  CameraSpec spec;
  spec.vfov_degrees = vfov_degrees;
  if (b.empty()) return spec;
  const glm::dvec3 lo(b.lo), hi(b.hi);
  const glm::dvec3 centre = (lo + hi) * 0.5;
  // A scene of one point (nothing visible) still gets a valid camera, at a
  // distance that scales with the scene's position, as everything else does.
  double radius = glm::length(hi - lo) * 0.5;
  if (!(radius > 0.0)) radius = glm::length(centre) > 0.0 ? glm::length(centre) : 1.0;
  const double dist = radius / std::sin(vfov_degrees * M_PI / 360.0);
  const glm::dvec3 dir = glm::normalize(glm::dvec3(0.35, 0.3, 1.0));
  spec.eye = centre + dir * dist;
  spec.look_at = centre;
  spec.up = glm::dvec3(0.0, 1.0, 0.0);
  return spec;
}

}  // namespace rayfold
