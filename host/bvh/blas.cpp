#include "bvh/blas.h"

#include <algorithm>
#include <climits>
#include <cmath>

#include "bvh/bvh_flatten.h"
#include "rf_geometry.h"
#include "util/parallel.h"
#include "util/pow2.h"
#include "util/timer.h"

namespace rayfold::core {
namespace {

// Meshes at least this large are built with every thread.
constexpr size_t kParallelMeshTriangles = 1u << 16;

// How many powers of two below the scene's largest mesh a mesh may lie and
// still share its tree space (choose_tree_exponents).
constexpr int kSharedTreeRange = 8;

}  // namespace

int scale_exponent(const Aabb& box) {
  if (box.empty()) return 0;
  const float big = std::max({std::fabs(box.lo.x), std::fabs(box.lo.y), std::fabs(box.lo.z), std::fabs(box.hi.x),
                              std::fabs(box.hi.y), std::fabs(box.hi.z)});
  return big > 0.0f && std::isfinite(big) ? std::ilogb(big) : 0;
}

void choose_tree_exponents(const std::vector<Aabb>& bounds, std::vector<int>& exponents) {
  int top = INT_MIN;
  for (const Aabb& b : bounds)
    if (!b.empty()) top = std::max(top, scale_exponent(b));
  exponents.resize(bounds.size());
  for (size_t m = 0; m < bounds.size(); ++m) {
    const int own = scale_exponent(bounds[m]);
    exponents[m] = !bounds[m].empty() && top - own <= kSharedTreeRange ? top : own;
  }
}

Xform object_from_tree(const BlasSet& blas, uint32_t mesh) { return uniform_scale(blas.tree_exponents[mesh]); }

BlasSet build_blas_set(const Scene& scene, const BuildOptions& options, unsigned threads) {
  const auto start = Clock::now();
  const size_t mesh_count = scene.meshes.size();
  BlasSet set;
  set.roots.resize(mesh_count);
  set.bounds.resize(mesh_count);
  set.tree_exponents.resize(mesh_count);
  // Tree-space positions, built from the mesh's vertices by an exact scaling
  // (util/pow2.h).
  std::vector<std::vector<glm::vec3>> positions(mesh_count);
  std::vector<BuildTree> trees(mesh_count);
  std::vector<size_t> unresolvable(mesh_count, 0);
  constexpr size_t kChunk = 1u << 14;
  auto bound_mesh = [&](size_t m, unsigned mesh_threads) {
    const Mesh& mesh = scene.meshes[m];
    const size_t tri_count = mesh.triangle_count();
    std::vector<Aabb> partial((tri_count + kChunk - 1) / kChunk);
    parallel_for(tri_count, mesh_threads, kChunk, [&](size_t begin, size_t end) {
      for (size_t i = 3 * begin; i < 3 * end; ++i) partial[begin / kChunk].grow(mesh.positions[mesh.indices[i]]);
    });
    Aabb object_bounds;
    for (const Aabb& b : partial) object_bounds.grow(b);
    set.bounds[m] = object_bounds;
  };
  auto build_mesh = [&](size_t m, unsigned mesh_threads) {
    const Mesh& mesh = scene.meshes[m];
    const size_t tri_count = mesh.triangle_count();
    const int e = set.tree_exponents[m];
    positions[m].resize(mesh.positions.size());
    const Pow2Scale tree_from_object(-e);
    parallel_for(mesh.positions.size(), mesh_threads, kChunk, [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i)
        for (int k = 0; k < 3; ++k) positions[m][i][k] = tree_from_object(mesh.positions[i][k]);
    });
    std::vector<Aabb> boxes(tri_count);
    std::vector<size_t> tiny((tri_count + kChunk - 1) / kChunk, 0);
    parallel_for(tri_count, mesh_threads, kChunk, [&](size_t begin, size_t end) {
      for (size_t t = begin; t < end; ++t) {
        for (int k = 0; k < 3; ++k) boxes[t].grow(positions[m][mesh.indices[3 * t + k]]);
        const glm::vec3 extent = boxes[t].extent();
        const float size = std::max({extent.x, extent.y, extent.z});
        if (size > 0.0f && size < 0x1p-60f) tiny[begin / kChunk]++;
      }
    });
    for (size_t n : tiny) unresolvable[m] += n;
    BuildOptions mesh_options = options;
    if (tri_count >= options.dense_triangles) mesh_options.intersection_cost = options.dense_intersection_cost;
    trees[m] = build_sah(boxes, mesh_options, mesh_threads);
  };
  // A large mesh is built by all threads, one after another; the others one
  // mesh per thread side by side, largest first.
  threads = resolve_threads(threads);
  std::vector<size_t> large, small;
  for (size_t m = 0; m < mesh_count; ++m)
    (scene.meshes[m].triangle_count() >= kParallelMeshTriangles ? large : small).push_back(m);
  std::stable_sort(small.begin(), small.end(), [&](size_t a, size_t b) {
    return scene.meshes[a].triangle_count() > scene.meshes[b].triangle_count();
  });
  for (size_t m : large) bound_mesh(m, threads);
  parallel_for(small.size(), threads, 1, [&](size_t i, size_t) { bound_mesh(small[i], 1); });
  choose_tree_exponents(set.bounds, set.tree_exponents);
  for (size_t m : large) build_mesh(m, threads);
  parallel_for(small.size(), threads, 1, [&](size_t i, size_t) { build_mesh(small[i], 1); });
  for (size_t n : unresolvable) set.unresolvable_triangles += n;

  double weighted_sah = 0.0;
  size_t weight = 0;
  size_t total_tris = 0;
  for (const BuildTree& tree : trees) total_tris += tree.order.size();
  // Triangles in leaf order, every mesh's after the one before, side by side.
  std::vector<size_t> tri_base(mesh_count + 1, 0);
  for (size_t m = 0; m < mesh_count; ++m) tri_base[m + 1] = tri_base[m] + trees[m].order.size();
  set.tris.resize(total_tris);
  parallel_for(total_tris, threads, size_t{1} << 14, [&](size_t begin, size_t end) {
    size_t m = static_cast<size_t>(std::upper_bound(tri_base.begin(), tri_base.end(), begin) - tri_base.begin()) - 1;
    for (size_t i = begin; i < end; ++i) {
      while (i >= tri_base[m + 1]) ++m;
      const Mesh& mesh = scene.meshes[m];
      const uint32_t t = trees[m].order[i - tri_base[m]];
      const std::vector<glm::vec3>& p = positions[m];
      rf_tri& tri = set.tris[i];
      for (int k = 0; k < 3; ++k) {
        tri.v0[k] = p[mesh.indices[3 * t]][k];
        tri.v1[k] = p[mesh.indices[3 * t + 1]][k];
        tri.v2[k] = p[mesh.indices[3 * t + 2]][k];
      }
      tri.prim = t;
      rf_tri_set_normal(&tri);
    }
  });
  // Every mesh's nodes after the one before, written side by side.
  std::vector<uint32_t> node_base(mesh_count + 1, 0);
  for (size_t m = 0; m < mesh_count; ++m)
    node_base[m + 1] = node_base[m] + static_cast<uint32_t>(flat_node_count(trees[m], node_base[m]));
  set.nodes.resize(node_base[mesh_count]);
  auto flatten_mesh = [&](size_t m, unsigned mesh_threads) {
    set.roots[m] = flatten_bvh_at(trees[m], static_cast<uint32_t>(tri_base[m]), nullptr, node_base[m],
                                  set.nodes.data() + node_base[m], mesh_threads);
  };
  for (size_t m : large) flatten_mesh(m, threads);
  parallel_for(small.size(), threads, 1, [&](size_t i, size_t) { flatten_mesh(small[i], 1); });
  for (size_t m = 0; m < mesh_count; ++m) {
    const BuildTree& tree = trees[m];
    set.max_depth = std::max(set.max_depth, tree.depth);
    weighted_sah += tree.sah_cost * tree.order.size();
    weight += tree.order.size();
  }
  if (set.nodes.size() % 2 != 0) set.nodes.push_back(rf_node{});  // the TLAS starts at an even index
  set.sah_cost = weight ? weighted_sah / weight : 0.0;
  set.build_ms = ms_since(start);
  return set;
}

}  // namespace rayfold::core
