#include "scene/scene.h"

#include <cmath>
#include <cstdio>

#include "util/errors.h"

namespace rayfold::core {

size_t Scene::triangle_count() const {
  size_t n = 0;
  for (const Instance& i : instances) n += meshes[i.mesh].triangle_count();
  return n;
}

size_t Scene::unique_triangle_count() const {
  size_t n = 0;
  for (const Mesh& m : meshes) n += m.triangle_count();
  return n;
}

// The vertices the triangles use, marked first and then read in order: a
// read through the indices is a cache miss a vertex on a large mesh (5 ms
// of the dragon's 39 ms load, twice: at the load and again before the
// build). min and max do not depend on the order.
Aabb Scene::mesh_bounds(uint32_t mesh) const {
  Aabb b;
  const Mesh& m = meshes[mesh];
  std::vector<uint8_t> used(m.positions.size(), 0);
  for (uint32_t idx : m.indices) used[idx] = 1;
  for (size_t v = 0; v < used.size(); ++v)
    if (used[v]) b.grow(m.positions[v]);
  return b;
}

Aabb Scene::world_bounds() const {
  std::vector<Aabb> per_mesh(meshes.size());
  for (uint32_t i = 0; i < meshes.size(); ++i) per_mesh[i] = mesh_bounds(i);
  Aabb b;
  for (const Instance& i : instances) b.grow(transform_bounds_conservative(i.world_from_object, per_mesh[i.mesh]));
  return b;
}

void check_world_range(const Scene& scene, const std::string& file) {
  // The traversal keys its ray cache by instance id and group in 32 bits
  // (kernels/rf_trace.h).
  if (scene.instances.size() > kMaxInstances)
    throw InputError(file, "the scene has " + std::to_string(scene.instances.size()) +
                               " instances; rayfold traces at most " + std::to_string(kMaxInstances));
  std::vector<Aabb> per_mesh(scene.meshes.size());
  for (uint32_t i = 0; i < scene.meshes.size(); ++i) per_mesh[i] = scene.mesh_bounds(i);
  for (const Instance& inst : scene.instances) {
    const Aabb& b = per_mesh[inst.mesh];
    if (b.empty()) continue;
    double reach = 0.0;
    for (int c = 0; c < 8; ++c) {
      const glm::dvec3 p((c & 1) ? b.hi.x : b.lo.x, (c & 2) ? b.hi.y : b.lo.y, (c & 4) ? b.hi.z : b.lo.z);
      const glm::dvec3 q = transform_point(inst.world_from_object, p);
      for (int k = 0; k < 3; ++k) reach = std::isnan(q[k]) ? INFINITY : std::max(reach, std::fabs(q[k]));
    }
    if (!(reach <= kMaxWorldCoordinate)) {
      char what[256];
      std::snprintf(what, sizeof what,
                    "node '%s' places mesh '%s' at coordinates up to %.3g; rayfold supports world coordinates up "
                    "to %.3g (2^126), where distances still fit a float",
                    inst.name.c_str(), scene.meshes[inst.mesh].name.c_str(), reach, kMaxWorldCoordinate);
      throw InputError(file, what);
    }
  }
}

}  // namespace rayfold::core
