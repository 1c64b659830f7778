// Optical flow between two views: where each pixel's surface point is seen
// in another view, for datasets of moving scenes and cameras. The point is
// the same barycentrics on the same triangle of the scene posed for the
// other view, so that moving nodes, morph targets and skins move it as they
// move the triangle.
#pragma once

#include <glm/mat4x4.hpp>
#include <string>

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

// For each pixel of `in` (a view `width` pixels wide) that hits: flow (2
// per pixel) is project(to, point) minus the pixel's own (x, y) (NaN where
// project is), and points (per pixel) the surface point in `other`'s pose,
// world space. On a miss flow is 0 and the point NaN. `other` is the scene
// posed for the other view, its instances and meshes those of the scene the
// hits are from (InputError naming `file` otherwise: a file whose pose changes its
// triangles). Each in double, flow rounded once.
void resolve_flow(const Scene& other, const HitPlanes& in, int width, const Camera& to, float* flow, glm::dvec3* points,
                  unsigned threads, const std::string& file);

}  // namespace rayfold::core
