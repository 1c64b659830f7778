#include "bvh/blas.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdint>
#include <string>
#include <unordered_map>

#include "bvh/bvh_flatten.h"
#include "rf_geometry.h"
#include "util/large_pages.h"
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

namespace {

// One tree to build: the triangles of its parts one part after another.
struct TreeSource {
  struct Part {
    uint32_t mesh;
    uint32_t inst;  // rf_tri::inst of its triangles
  };
  std::vector<Part> parts;
  std::vector<size_t> first{0};  // each part's first triangle in the tree, then the total
  size_t largest_part = 0;       // the dense rule's mesh size (BuildOptions::dense_triangles)
  void add(const Scene& scene, uint32_t mesh, uint32_t inst) {
    const size_t n = scene.meshes[mesh].triangle_count();
    parts.push_back({mesh, inst});
    first.push_back(first.back() + n);
    largest_part = std::max(largest_part, n);
  }
  size_t triangles() const { return first.back(); }
  // The part holding triangle i of the tree.
  size_t part_of(size_t i) const {
    return static_cast<size_t>(std::upper_bound(first.begin(), first.end(), i) - first.begin()) - 1;
  }
};

// BlasSet::traced_by: static instances (invertible, with triangles, not
// dynamic) grouped by their world_from_object's bits and their mesh's tree
// exponent, each group under its lowest id.
std::vector<uint32_t> merge_groups(const Scene& scene, const std::vector<int>& exponents, const MergeOptions& merge) {
  const size_t n = scene.instances.size();
  std::vector<uint32_t> traced_by(n);
  std::unordered_map<std::string, uint32_t> first_of;
  for (size_t i = 0; i < n; ++i) {
    traced_by[i] = static_cast<uint32_t>(i);
    const Instance& inst = scene.instances[i];
    Xform inverse;
    const bool is_static = merge.enabled && !(i < merge.dynamic.size() && merge.dynamic[i]);
    if (!is_static || scene.meshes[inst.mesh].triangle_count() == 0 ||
        !affine_inverse(inst.world_from_object, &inverse))
      continue;
    std::string key(reinterpret_cast<const char*>(&inst.world_from_object), sizeof(Xform));
    key.append(reinterpret_cast<const char*>(&exponents[inst.mesh]), sizeof(int));
    traced_by[i] = first_of.emplace(std::move(key), static_cast<uint32_t>(i)).first->second;
  }
  return traced_by;
}

}  // namespace

BlasSet build_blas_set(const Scene& scene, const BuildOptions& options, unsigned threads, const MergeOptions& merge,
                       const std::function<void(const BlasSet&)>& beside_fill) {
  const auto start = Clock::now();
  const size_t mesh_count = scene.meshes.size(), instance_count = scene.instances.size();
  BlasSet set;
  set.roots.assign(mesh_count, RF_INVALID);
  set.bounds.resize(mesh_count);
  set.tree_exponents.resize(mesh_count);
  constexpr size_t kChunk = 1u << 14;
  threads = resolve_threads(threads);
  // A large mesh or tree is worked on by all threads, one after another;
  // the others one per thread side by side, largest first.
  auto by_size = [&](size_t count, auto&& size_of, auto&& work) {
    std::vector<size_t> large, small;
    for (size_t k = 0; k < count; ++k) (size_of(k) >= kParallelMeshTriangles ? large : small).push_back(k);
    std::stable_sort(small.begin(), small.end(), [&](size_t a, size_t b) { return size_of(a) > size_of(b); });
    for (size_t k : large) work(k, threads);
    parallel_for(small.size(), threads, 1, [&](size_t i, size_t) { work(small[i], 1u); });
  };
  auto mesh_size = [&](size_t m) { return scene.meshes[m].triangle_count(); };
  by_size(mesh_count, mesh_size, [&](size_t m, unsigned mesh_threads) {
    const Mesh& mesh = scene.meshes[m];
    const size_t tri_count = mesh.triangle_count();
    std::vector<Aabb> partial((tri_count + kChunk - 1) / kChunk);
    parallel_for(tri_count, mesh_threads, kChunk, [&](size_t begin, size_t end) {
      for (size_t i = 3 * begin; i < 3 * end; ++i) partial[begin / kChunk].grow(mesh.positions[mesh.indices[i]]);
    });
    Aabb object_bounds;
    for (const Aabb& b : partial) object_bounds.grow(b);
    set.bounds[m] = object_bounds;
  });
  choose_tree_exponents(set.bounds, set.tree_exponents);

  // The trees: each mesh's that an instance traces alone (or that no
  // instance uses), then each group's of two or more members.
  set.traced_by = merge_groups(scene, set.tree_exponents, merge);
  std::vector<uint32_t> members(instance_count, 0);
  for (uint32_t first : set.traced_by) members[first]++;
  set.merged.assign(instance_count, 0);
  std::vector<char> mesh_tree(mesh_count, 1), mesh_used(mesh_count, 0);
  for (size_t i = 0; i < instance_count; ++i) {
    set.merged[i] = members[set.traced_by[i]] > 1;
    const uint32_t m = scene.instances[i].mesh;
    if (!mesh_used[m]) mesh_tree[m] = 0;
    mesh_used[m] = 1;
    if (!set.merged[i]) mesh_tree[m] = 1;
  }
  std::vector<TreeSource> sources;
  std::vector<uint32_t> source_mesh;  // the mesh of a mesh tree, RF_INVALID for a merged one
  for (uint32_t m = 0; m < mesh_count; ++m) {
    if (!mesh_tree[m]) continue;
    sources.emplace_back().add(scene, m, 0);
    source_mesh.push_back(m);
  }
  std::vector<size_t> group_source(instance_count, SIZE_MAX);
  for (size_t i = 0; i < instance_count; ++i) {
    if (!set.merged[i]) continue;
    const uint32_t first = set.traced_by[i];
    if (group_source[first] == SIZE_MAX) {
      group_source[first] = sources.size();
      sources.emplace_back();
      source_mesh.push_back(RF_INVALID);
    }
    sources[group_source[first]].add(scene, scene.instances[i].mesh, static_cast<uint32_t>(i - first));
  }

  // Tree space is object space scaled exactly (util/pow2.h), which keeps
  // the order of coordinates: a triangle's tree-space box is its object
  // box scaled, and its tree-space vertices are scaled where the fill
  // reads them. A tree-space copy of every mesh's vertices, made first, was
  // a pass over them all and their size again in memory.
  std::vector<Pow2Scale> tree_from_object;
  tree_from_object.reserve(mesh_count);
  for (size_t m = 0; m < mesh_count; ++m) tree_from_object.emplace_back(-set.tree_exponents[m]);
  const size_t tree_count = sources.size();
  std::vector<BuildTree> trees(tree_count);
  std::vector<size_t> unresolvable(tree_count, 0);
  // Per triangle of a tree of several parts, its part, written as the
  // boxes are: the fill below reads triangles in leaf order, where a
  // search of the parts' starts per triangle (the car's tree has 1,075)
  // mispredicted at every level and took a third of the fill.
  std::vector<LargeArray<uint32_t>> part_at(tree_count);
  auto tree_size = [&](size_t s) { return sources[s].triangles(); };
  by_size(tree_count, tree_size, [&](size_t s, unsigned tree_threads) {
    const TreeSource& src = sources[s];
    const size_t tri_count = src.triangles();
    LargeArray<Aabb> boxes(tri_count);  // each written once below
    std::vector<size_t> tiny((tri_count + kChunk - 1) / kChunk, 0);
    if (src.parts.size() > 1) part_at[s] = LargeArray<uint32_t>(tri_count);  // each written once below
    uint32_t* const parts = part_at[s].data();
    parallel_for(tri_count, tree_threads, kChunk, [&](size_t begin, size_t end) {
      for (size_t p = src.part_of(begin), t = begin; t < end; ++t) {
        while (t >= src.first[p + 1]) ++p;
        if (parts) parts[t] = static_cast<uint32_t>(p);
        const Mesh& mesh = scene.meshes[src.parts[p].mesh];
        const Pow2Scale& scale = tree_from_object[src.parts[p].mesh];
        const size_t local = t - src.first[p];
        Aabb box;
        for (int k = 0; k < 3; ++k) box.grow(mesh.positions[mesh.indices[3 * local + k]]);
        for (int c = 0; c < 3; ++c) {
          box.lo[c] = scale(box.lo[c]);
          box.hi[c] = scale(box.hi[c]);
        }
        boxes[t] = box;
        const glm::vec3 extent = box.extent();
        const float size = std::max({extent.x, extent.y, extent.z});
        if (size > 0.0f && size < 0x1p-60f) tiny[begin / kChunk]++;
      }
    });
    for (size_t n : tiny) unresolvable[s] += n;
    BuildOptions tree_options = options;
    if (src.largest_part >= options.dense_triangles) tree_options.intersection_cost = options.dense_intersection_cost;
    trees[s] = build_sah(boxes.data(), boxes.size(), tree_options, tree_threads);
  });
  for (size_t n : unresolvable) set.unresolvable_triangles += n;

  double weighted_sah = 0.0;
  size_t weight = 0;
  std::vector<size_t> tri_base(tree_count + 1, 0);
  for (size_t s = 0; s < tree_count; ++s) tri_base[s + 1] = tri_base[s] + trees[s].order.size();
  // Every tree's nodes after the one before, written side by side.
  std::vector<uint32_t> node_base(tree_count + 1, 0);
  for (size_t s = 0; s < tree_count; ++s)
    node_base[s + 1] = node_base[s] + static_cast<uint32_t>(flat_node_count(trees[s], node_base[s]));
  // The TLAS starts at an even index: a padding node where the count is odd.
  set.nodes.resize(node_base[tree_count] + node_base[tree_count] % 2);  // each written below
  if (node_base[tree_count] % 2 != 0) set.nodes.back() = rf_node{};
  std::vector<uint32_t> tree_roots(tree_count);
  by_size(tree_count, tree_size, [&](size_t s, unsigned tree_threads) {
    tree_roots[s] = flatten_bvh_at(trees[s], static_cast<uint32_t>(tri_base[s]), nullptr, node_base[s],
                                   set.nodes.data() + node_base[s], tree_threads);
  });
  for (size_t s = 0; s < tree_count; ++s)
    if (source_mesh[s] != RF_INVALID) set.roots[source_mesh[s]] = tree_roots[s];
  set.instance_roots.assign(instance_count, RF_INVALID);
  for (size_t i = 0; i < instance_count; ++i) {
    if (!set.merged[i])
      set.instance_roots[i] = set.roots[scene.instances[i].mesh];
    else if (set.traced_by[i] == i)
      set.instance_roots[i] = tree_roots[group_source[i]];
  }
  for (size_t s = 0; s < tree_count; ++s) {
    const BuildTree& tree = trees[s];
    set.max_depth = std::max(set.max_depth, tree.depth);
    weighted_sah += tree.sah_cost * tree.order.size();
    weight += tree.order.size();
  }
  // The build trees' nodes are flattened: gone before the triangles and
  // beside_fill's arrays come (kept, they raised the car's peak by 28 bytes a
  // triangle). Their leaf orders stay for the fill.
  for (BuildTree& tree : trees) PageAlignedVector<BuildNode>().swap(tree.nodes);
  // Triangles in leaf order, every tree's after the one before, side by side.
  set.tris.resize(tri_base[tree_count]);
  // In leaf order the source triangles are read at random: each one's
  // indices and then its vertices were cache misses in turn (the fill took
  // 10 to 27 ms of the armadillo's and the dragon's builds). The indices of
  // the triangle kAhead places on, and the vertices of the one half as far
  // on, are asked for early.
  constexpr size_t kAhead = 16;
  struct Source {
    const uint32_t* indices;     // its three
    const glm::vec3* positions;  // its mesh's, in object space
    const Pow2Scale* tree_from_object;
    uint32_t prim, inst;
  };
  auto source_of = [&](size_t s, size_t i) {
    const TreeSource& src = sources[s];
    const size_t t = trees[s].order[i - tri_base[s]];
    const size_t at = part_at[s].empty() ? 0 : part_at[s][t];
    const TreeSource::Part& part = src.parts[at];
    const size_t local = t - src.first[at];
    return Source{scene.meshes[part.mesh].indices.data() + 3 * local, scene.meshes[part.mesh].positions.data(),
                  &tree_from_object[part.mesh], static_cast<uint32_t>(local), part.inst};
  };
  // The nodes are done: `beside_fill` runs on this thread while the others
  // fill, then this one joins them.
  auto fill = [&](size_t begin, size_t end) {
    size_t s = static_cast<size_t>(std::upper_bound(tri_base.begin(), tri_base.end(), begin) - tri_base.begin()) - 1;
    for (size_t i = begin; i < end; ++i) {
      while (i >= tri_base[s + 1]) ++s;
      if (i + kAhead < tri_base[s + 1]) __builtin_prefetch(source_of(s, i + kAhead).indices);
      if (i + kAhead / 2 < tri_base[s + 1]) {
        const Source ahead = source_of(s, i + kAhead / 2);
        for (int k = 0; k < 3; ++k) __builtin_prefetch(ahead.positions + ahead.indices[k]);
      }
      const Source src = source_of(s, i);
      rf_tri& tri = set.tris[i];
      const Pow2Scale& scale = *src.tree_from_object;
      for (int k = 0; k < 3; ++k) {
        tri.v0[k] = scale(src.positions[src.indices[0]][k]);
        tri.v1[k] = scale(src.positions[src.indices[1]][k]);
        tri.v2[k] = scale(src.positions[src.indices[2]][k]);
      }
      tri.prim = src.prim;
      tri.inst = src.inst;
      rf_tri_set_normal(&tri);
    }
  };
  parallel_for_beside(set.tris.size(), threads, size_t{1} << 14, fill,
                      beside_fill ? std::function<void()>([&] { beside_fill(set); }) : std::function<void()>());
  part_at.clear();
  set.sah_cost = weight ? weighted_sah / weight : 0.0;
  set.build_ms = ms_since(start);
  return set;
}

}  // namespace rayfold::core
