#include "scene.h"

namespace rayfold {

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

Aabb Scene::mesh_bounds(uint32_t mesh) const {
  Aabb b;
  const Mesh& m = meshes[mesh];
  for (uint32_t idx : m.indices) b.grow(m.positions[idx]);
  return b;
}

Aabb Scene::world_bounds() const {
  std::vector<Aabb> per_mesh(meshes.size());
  for (uint32_t i = 0; i < meshes.size(); ++i) per_mesh[i] = mesh_bounds(i);
  Aabb b;
  for (const Instance& i : instances) b.grow(transform_bounds_conservative(i.world_from_object, per_mesh[i.mesh]));
  return b;
}

}  // namespace rayfold
