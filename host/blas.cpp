#include "blas.h"

#include <algorithm>
#include <chrono>

#include "bvh_flatten.h"
#include "parallel.h"

namespace rayfold {

BlasSet build_blas_set(const Scene& scene, const BuildOptions& options, unsigned threads) {
  const auto start = std::chrono::steady_clock::now();
  const size_t mesh_count = scene.meshes.size();
  std::vector<BuildTree> trees(mesh_count);
  parallel_for(mesh_count, threads, 1, [&](size_t m, size_t) {
    const Mesh& mesh = scene.meshes[m];
    std::vector<Aabb> boxes(mesh.triangle_count());
    for (size_t t = 0; t < boxes.size(); ++t)
      for (int k = 0; k < 3; ++k) boxes[t].grow(mesh.positions[mesh.indices[3 * t + k]]);
    trees[m] = build_sah(boxes, options);
  });

  BlasSet set;
  set.roots.resize(mesh_count);
  set.bounds.resize(mesh_count);
  double weighted_sah = 0.0;
  size_t weight = 0;
  for (size_t m = 0; m < mesh_count; ++m) {
    const Mesh& mesh = scene.meshes[m];
    const BuildTree& tree = trees[m];
    const uint32_t tri_base = static_cast<uint32_t>(set.tris.size());
    for (uint32_t t : tree.order) {
      rf_tri tri{};
      const glm::vec3* v[3] = {&mesh.positions[mesh.indices[3 * t]], &mesh.positions[mesh.indices[3 * t + 1]],
                               &mesh.positions[mesh.indices[3 * t + 2]]};
      for (int k = 0; k < 3; ++k) {
        tri.v0[k] = (*v[0])[k];
        tri.v1[k] = (*v[1])[k];
        tri.v2[k] = (*v[2])[k];
      }
      tri.prim = t;
      set.tris.push_back(tri);
    }
    set.roots[m] = flatten_bvh(tree, tri_base, nullptr, 0, set.nodes);
    if (!tree.nodes.empty()) set.bounds[m] = tree.nodes[0].bounds;
    set.max_depth = std::max(set.max_depth, tree.depth);
    weighted_sah += tree.sah_cost * tree.order.size();
    weight += tree.order.size();
  }
  if (set.nodes.size() % 2 != 0) set.nodes.push_back(rf_node{});  // the TLAS starts at an even index
  set.sah_cost = weight ? weighted_sah / weight : 0.0;
  set.build_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return set;
}

}  // namespace rayfold
