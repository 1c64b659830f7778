// Optical flow between two views: where each pixel's surface point is seen
// in another view, for datasets of moving scenes and cameras. The point is
// the same barycentrics on the same triangle of the scene posed for the
// other view, so that moving nodes, morph targets and skins move it as they
// move the triangle.
#pragma once

#include <limits>
#include <string>

#include <glm/mat4x4.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include "resolve/resolve.h"

namespace rayfold::core {

// The continuous pixel coordinates of a world-space point in the camera's
// image, in the units of its pixel indices (pixel (x, y)'s centre is (x, y),
// +y down), inverting exactly the rays the camera traces; NaN where a
// perspective camera has the point at or behind its eye's plane, or an
// orthographic one behind its image plane.
glm::dvec2 project(const Camera& camera, const glm::dvec3& world);
// The same with the camera's constants worked out once, for many points
// (one division a point).
struct Projection {
  explicit Projection(const Camera& camera);
  glm::dvec2 operator()(const glm::dvec3& world) const;
  glm::dmat4 camera_from_world;
  bool orthographic;
  glm::dvec2 half_inverse_scale, offset;
};

// Inline: a call a pixel through the library's symbol table cost a tenth
// of the flow's time.
inline glm::dvec2 Projection::operator()(const glm::dvec3& world) const {
  const glm::dvec3 p = glm::dvec3(camera_from_world * glm::dvec4(world, 1.0));
  double a = p.x, b = p.y;
  // Behind the eye, or an orthographic view's image plane, where its rays start.
  if (orthographic ? !(p.z <= 0.0) : !(p.z < 0.0)) return glm::dvec2(std::numeric_limits<double>::quiet_NaN());
  if (!orthographic) {
    const double inverse_depth = -1.0 / p.z;
    a *= inverse_depth;
    b *= inverse_depth;
  }
  // exact_direction's pixel (x, y): a = scale_x (2x + kx0 + frac_x), b = scale_y (ky0 - 2y + frac_y).
  return glm::dvec2(a * half_inverse_scale.x + offset.x, offset.y - b * half_inverse_scale.y);
}

// For each pixel of `in` (a view `width` pixels wide) that hits: flow (2
// per pixel) is project(to, point) minus the pixel's own (x, y) (NaN where
// project is), and points (per pixel) the surface point in `other`'s pose,
// world space: the triangle's corners moved to world space there,
// interpolated (the position channel's rule, resolve.h). On a miss flow is 0 and the point NaN. `other` is the scene
// posed for the other view, its instances and meshes those of the scene the
// hits are from (InputError naming `file` otherwise: a file whose pose changes its
// triangles). Each in double, flow rounded once.
void resolve_flow(const Scene& other, const HitPlanes& in, int width, const Camera& to, float* flow, glm::dvec3* points,
                  unsigned threads, const std::string& file);

}  // namespace rayfold::core
