#include "scene/camera.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_inverse.hpp>

#include "util/errors.h"

namespace rayfold::core {
namespace {

void check_size(int width, int height) {
  if (width <= 0 || height <= 0 || width > RF_MAX_IMAGE_SIDE || height > RF_MAX_IMAGE_SIDE) {
    std::ostringstream s;
    s << "image size " << width << "x" << height << " is out of range (1.." << RF_MAX_IMAGE_SIDE << " per side)";
    throw InputError("", s.str());
  }
}

// Sets params from the exact scales and offsets: kx0 and ky0 are the
// integer parts of the principal point in half pixels, frac_x and frac_y
// what is left.
void set_rays(Camera& cam, double scale_x, double scale_y, int kx0, int ky0, double frac_x, double frac_y) {
  cam.scale_x = scale_x;
  cam.scale_y = scale_y;
  cam.frac_x = frac_x;
  cam.frac_y = frac_y;
  cam.params.scale_x = static_cast<float>(scale_x);
  cam.params.scale_y = static_cast<float>(scale_y);
  cam.params.kx0 = kx0;
  cam.params.ky0 = ky0;
  cam.params.frac_x = static_cast<float>(frac_x);
  cam.params.frac_y = static_cast<float>(frac_y);
  cam.params.width = cam.width;
  cam.params.height = cam.height;
  // The partner of column x has coordinate -(2x + kx0), i.e. column -kx0 - x.
  cam.params.xpair = -kx0;
  cam.params.ypair = ky0;
  // One view, unfolded, until a frame says otherwise (frame_camera).
  cam.params.views = 1;
  cam.params.group_shift = 0;
  cam.params.slot_mirrors = 0;
  cam.params.view_rep = 1;
}

}  // namespace

Camera make_camera(const CameraSpec& spec, int width, int height, double shift_x, double shift_y) {
  check_size(width, height);
  if (!(std::fabs(shift_x) <= 100.0 && std::fabs(shift_y) <= 100.0))
    throw InputError("",
                     "lens shift must be finite and at most 100 half-images (ray coordinates must stay exact floats)");
  if (!spec.orthographic && !(spec.vfov_degrees > 0.0 && spec.vfov_degrees < 180.0))
    throw InputError("", "vertical field of view must be in (0, 180) degrees");
  if (spec.orthographic && !(spec.ymag > 0.0 && spec.ymag <= kMaxWorldCoordinate))
    throw InputError("", "an orthographic camera's ymag must be positive and at most 2^126");
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
  // in units of half a pixel from the optical axis; orthographic, at
  // (2x + kx0) / H * ymag world units.
  const double scale = spec.orthographic ? spec.ymag / height : std::tan(spec.vfov_degrees * M_PI / 360.0) / height;
  set_rays(cam, scale, scale, 1 - width + static_cast<int>(std::lround(shift_x * width)),
           height - 1 + static_cast<int>(std::lround(shift_y * height)), 0.0, 0.0);
  if (spec.orthographic) {
    cam.vfov_degrees = 0.0;
    cam.params.ortho = 1;
  }
  return cam;
}

Camera make_camera(const Xform& world_from_camera, const Intrinsics& k, int width, int height) {
  check_size(width, height);
  if (!(k.fx > 0.0 && k.fy > 0.0 && std::isfinite(k.fx) && std::isfinite(k.fy)))
    throw InputError("", "focal lengths fx, fy must be positive and finite (pixels)");
  if (!(std::fabs(k.cx - 0.5 * width) <= 100.0 * width && std::fabs(k.cy - 0.5 * height) <= 100.0 * height))
    throw InputError("", "principal point cx, cy must be finite and at most 100 images from the centre");
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite(world_from_camera[c][r])) throw InputError("", "camera-to-world matrix is not finite");
  if (world_from_camera[0][3] != 0.0 || world_from_camera[1][3] != 0.0 || world_from_camera[2][3] != 0.0 ||
      world_from_camera[3][3] != 1.0)
    throw InputError("", "camera-to-world matrix must be affine (last row 0, 0, 0, 1)");
  const glm::dvec3 eye(world_from_camera[3]);
  for (int i = 0; i < 3; ++i)
    if (!(std::fabs(eye[i]) <= kMaxWorldCoordinate))
      throw InputError("", "eye must lie within world coordinates of +-8.5e37 (2^126)");
  // Datasets store rotations rounded to float: accept what is rigid to 1e-5
  // and make it orthonormal (Gram-Schmidt from the view axis), so that depths
  // are distances. A rotation orthonormal to double rounding (a pose this
  // library wrote) is kept bit for bit: the same view renders the same bits.
  glm::dvec3 axis[3] = {glm::dvec3(world_from_camera[0]), glm::dvec3(world_from_camera[1]),
                        glm::dvec3(world_from_camera[2])};
  double worst = 0.0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) worst = std::max(worst, std::fabs(glm::dot(axis[i], axis[j]) - (i == j ? 1.0 : 0.0)));
  if (!(worst <= 1e-5)) {
    std::ostringstream s;
    s << "camera-to-world rotation is not orthonormal (off by " << worst
      << "; scale and shear are not allowed: depths are distances)";
    throw InputError("", s.str());
  }
  if (glm::dot(glm::cross(axis[0], axis[1]), axis[2]) < 0.0)
    throw InputError("", "camera-to-world rotation is a mirror (determinant -1)");
  glm::dvec3 u = axis[0], v = axis[1], w = axis[2];
  if (worst > 1e-14) {
    w = glm::normalize(axis[2]);
    u = glm::normalize(axis[0] - glm::dot(axis[0], w) * w);
    v = glm::cross(w, u);
  }

  Camera cam;
  cam.width = width;
  cam.height = height;
  cam.vfov_degrees = 2.0 * std::atan(0.5 * height / k.fy) * 180.0 / M_PI;
  cam.world_from_camera = Xform(glm::dvec4(u, 0.0), glm::dvec4(v, 0.0), glm::dvec4(w, 0.0), glm::dvec4(eye, 1.0));
  cam.camera_from_world = glm::affineInverse(cam.world_from_camera);
  // Pixel (x, y) looks along ((x + 0.5 - cx) / fx, -(y + 0.5 - cy) / fy, -1)
  // = (sx * (2x + 1 - 2cx), sy * (2cy - 1 - 2y), -1) with s = 1 / (2f).
  const double n = std::round(2.0 * k.cx), m = std::round(2.0 * k.cy);
  set_rays(cam, 0.5 / k.fx, 0.5 / k.fy, 1 - static_cast<int>(n), static_cast<int>(m) - 1, n - 2.0 * k.cx,
           2.0 * k.cy - m);
  return cam;
}

Intrinsics intrinsics(const Camera& c) {
  Intrinsics k;
  k.fx = 0.5 / c.scale_x;
  k.fy = 0.5 / c.scale_y;
  k.cx = 0.5 * (1.0 - c.params.kx0 - c.frac_x);
  k.cy = 0.5 * (c.params.ky0 + 1.0 + c.frac_y);
  return k;
}

glm::dvec3 exact_direction(const Camera& c, int x, int y) {
  if (c.params.ortho) return glm::dvec3(0.0, 0.0, -1.0);
  return glm::dvec3(c.scale_x * ((2 * x + c.params.kx0) + c.frac_x), c.scale_y * ((c.params.ky0 - 2 * y) + c.frac_y),
                    -1.0);
}

glm::dvec3 exact_origin(const Camera& c, int x, int y) {
  if (!c.params.ortho) return glm::dvec3(0.0);
  return glm::dvec3(c.scale_x * ((2 * x + c.params.kx0) + c.frac_x), c.scale_y * ((c.params.ky0 - 2 * y) + c.frac_y),
                    0.0);
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

std::array<CameraSpec, 2> stereo_specs(const CameraSpec& centre, double baseline) {
  const glm::dvec3 right(make_camera(centre, 2, 2).world_from_camera[0]);
  std::array<CameraSpec, 2> eyes{centre, centre};
  for (int k = 0; k < 2; ++k) {
    const double sign = k == 0 ? -0.5 : 0.5;
    eyes[k].eye += sign * baseline * right;
    eyes[k].look_at += sign * baseline * right;
  }
  return eyes;
}

}  // namespace rayfold::core
