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

glm::dvec2 project(const Camera& camera, const glm::dvec3& world) { return Projection(camera)(world); }

void resolve_flow(const Scene& other, const HitPlanes& in, int width, const Camera& to, float* flow, glm::dvec3* points,
                  unsigned threads, const std::string& file) {
  RF_CHECK(in.instance && in.primitive && in.barycentrics, "flow needs the hits' ids and barycentrics");
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const Projection project_to(to);
  parallel_for(in.pixels, threads, size_t{1} << 13, [&](size_t begin, size_t end) {
    // The triangle's corners in the other pose, world space, once for the
    // run of pixels on it (as the position channel's).
    uint32_t inst = RF_INVALID, tri = RF_INVALID;
    glm::dvec3 world[3];
    // The pixel's column and row, stepped along (a division a pixel cost as much as the projection).
    size_t x = begin % static_cast<size_t>(width), y = begin / static_cast<size_t>(width);
    for (size_t p = begin; p < end; ++p, x = x + 1 == static_cast<size_t>(width) ? (++y, 0) : x + 1) {
      if (in.instance[p] == RF_INVALID) {
        if (flow) flow[2 * p] = flow[2 * p + 1] = 0.0f;
        if (points) points[p] = glm::dvec3(nan);
        continue;
      }
      if (in.instance[p] != inst || in.primitive[p] != tri) {
        inst = in.instance[p];
        tri = in.primitive[p];
        if (inst >= other.instances.size())
          throw InputError(file, "flow: the other view's pose has " + std::to_string(other.instances.size()) +
                                     " instances, not instance " + std::to_string(inst));
        const Instance& instance = other.instances[inst];
        const Mesh& mesh = other.meshes[instance.mesh];
        if (tri >= mesh.triangle_count())
          throw InputError(file, "flow: in the other view's pose instance " + std::to_string(inst) + "'s mesh has " +
                                     std::to_string(mesh.triangle_count()) + " triangles, not triangle " +
                                     std::to_string(tri));
        world_corners(mesh, tri, instance.world_from_object, world);
      }
      const double u = in.barycentrics[2 * p], v = in.barycentrics[2 * p + 1];
      const double b0 = (1.0 - u) - v;
      const glm::dvec3 w = b0 * world[0] + u * world[1] + v * world[2];
      if (points) points[p] = w;
      if (flow) {
        const glm::dvec2 at = project_to(w);
        flow[2 * p] = static_cast<float>(at.x - static_cast<double>(x));
        flow[2 * p + 1] = static_cast<float>(at.y - static_cast<double>(y));
      }
    }
  });
}

}  // namespace rayfold::core
