#include "resolve/flow.h"

#include <cmath>
#include <limits>

#include <glm/mat4x4.hpp>

#include "device_layout.h"
#include "util/errors.h"
#include "util/parallel.h"

namespace rayfold::core {

Projection::Projection(const Camera& c)
    : camera_from_world(c.camera_from_world),
      orthographic(c.params.ortho != 0),
      half_inverse_scale(0.5 / c.scale_x, 0.5 / c.scale_y),
      offset(-(static_cast<double>(c.params.kx0) + c.frac_x) / 2.0,
             (static_cast<double>(c.params.ky0) + c.frac_y) / 2.0) {}

glm::dvec2 Projection::operator()(const glm::dvec3& world) const {
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

glm::dvec2 project(const Camera& camera, const glm::dvec3& world) { return Projection(camera)(world); }

void resolve_flow(const Scene& other, const HitPlanes& in, int width, const Camera& to, float* flow, glm::dvec3* points,
                  unsigned threads, const std::string& file) {
  RF_CHECK(in.instance && in.primitive && in.barycentrics, "flow needs the hits' ids and barycentrics");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Projection project_to(to);
  parallel_for(in.pixels, threads, size_t{1} << 13, [&](size_t begin, size_t end) {
    for (size_t p = begin; p < end; ++p) {
      const uint32_t inst = in.instance[p];
      if (inst == RF_INVALID) {
        if (flow) flow[2 * p] = flow[2 * p + 1] = 0.0f;
        if (points) points[p] = glm::dvec3(nan);
        continue;
      }
      if (inst >= other.instances.size())
        throw InputError(file, "flow: the other view's pose has " + std::to_string(other.instances.size()) +
                                   " instances, not instance " + std::to_string(inst));
      const Instance& instance = other.instances[inst];
      const Mesh& mesh = other.meshes[instance.mesh];
      const uint32_t tri = in.primitive[p];
      if (tri >= mesh.triangle_count())
        throw InputError(file, "flow: in the other view's pose instance " + std::to_string(inst) + "'s mesh has " +
                                   std::to_string(mesh.triangle_count()) + " triangles, not triangle " +
                                   std::to_string(tri));
      const uint32_t* i = &mesh.indices[3 * tri];
      const double u = in.barycentrics[2 * p], v = in.barycentrics[2 * p + 1];
      const double b0 = (1.0 - u) - v;
      const glm::dvec3 o = b0 * glm::dvec3(mesh.positions[i[0]]) + u * glm::dvec3(mesh.positions[i[1]]) +
                           v * glm::dvec3(mesh.positions[i[2]]);
      const glm::dvec3 w = glm::dvec3(instance.world_from_object * glm::dvec4(o, 1.0));
      if (points) points[p] = w;
      if (flow) {
        const glm::dvec2 at = project_to(w);
        flow[2 * p] = static_cast<float>(at.x - static_cast<double>(p % width));
        flow[2 * p + 1] = static_cast<float>(at.y - static_cast<double>(p / width));
      }
    }
  });
}

}  // namespace rayfold::core
