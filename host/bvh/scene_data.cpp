#include "bvh/scene_data.h"

#include <algorithm>
#include <cmath>
#include <queue>

#include "bvh/wide_bvh.h"
#include "util/errors.h"
#include "util/large_pages.h"

namespace rayfold::core {
namespace {

// In double: world-space areas of float boxes overflow a float from about
// 1e19 on, and the braid must choose the same cut at every scale.
double half_area(const Aabb& b) {
  if (b.empty()) return 0.0;
  const glm::dvec3 e = glm::dvec3(b.hi) - glm::dvec3(b.lo);
  return e.x * e.y + e.y * e.z + e.z * e.x;
}

// Opens the largest (in world space) BLAS nodes of all instances until the
// budget is spent; the open frontier is each instance's cut.
void choose_braid_cuts(const Scene& scene, const BlasSet& blas, SceneData& data, const BraidOptions& opt) {
  struct Item {
    double area;
    uint32_t instance, node;
    bool operator<(const Item& o) const {
      if (area != o.area) return area < o.area;
      if (instance != o.instance) return instance > o.instance;
      return node > o.node;
    }
  };
  const size_t n = scene.instances.size();
  std::vector<std::vector<uint32_t>> cuts(n);
  std::priority_queue<Item> open;
  auto world_area = [&](uint32_t i, uint32_t node) {
    Aabb b;
    b.grow(glm::vec3(blas.nodes[node].bmin[0], blas.nodes[node].bmin[1], blas.nodes[node].bmin[2]));
    b.grow(glm::vec3(blas.nodes[node].bmax[0], blas.nodes[node].bmax[1], blas.nodes[node].bmax[2]));
    const Instance& inst = scene.instances[i];
    return half_area(transform_bounds_conservative(inst.world_from_object * object_from_tree(blas, inst.mesh), b));
  };
  size_t items = 0;
  for (uint32_t i = 0; i < n; ++i) {
    const uint32_t root = blas.instance_roots[i];
    if (!data.renderable[i] || root == RF_INVALID) continue;  // a merged tree is traced once, by its first member
    open.push({world_area(i, root), i, root});
    ++items;
  }
  if (opt.enabled) {
    const size_t budget = std::max(opt.min_items, opt.items_per_instance * items);
    const double min_area = opt.min_area_fraction * half_area(data.world_bounds);
    const double loose = opt.loose_ratio;
    while (!open.empty() && open.top().area >= min_area) {
      const Item top = open.top();
      const rf_node& node = blas.nodes[top.node];
      open.pop();
      if ((node.meta & RF_NODE_COUNT_MASK) != 0) {  // a leaf cannot open
        cuts[top.instance].push_back(top.node);
        continue;
      }
      const double left = world_area(top.instance, node.first), right = world_area(top.instance, node.first + 1);
      if (items >= budget && !(left + right < loose * top.area)) {
        cuts[top.instance].push_back(top.node);
        continue;
      }
      open.push({left, top.instance, node.first});
      open.push({right, top.instance, node.first + 1});
      ++items;
    }
  }
  for (; !open.empty(); open.pop()) cuts[open.top().instance].push_back(open.top().node);
  data.braid_offsets.assign(1, 0);
  for (uint32_t i = 0; i < n; ++i) {
    std::sort(cuts[i].begin(), cuts[i].end());
    data.braid_nodes.insert(data.braid_nodes.end(), cuts[i].begin(), cuts[i].end());
    data.braid_offsets.push_back(static_cast<uint32_t>(data.braid_nodes.size()));
  }
}

}  // namespace

SceneData prepare_scene(const Scene& scene, unsigned threads, const BraidOptions& braid, const MergeOptions& merge) {
  check_world_range(scene, "");
  const BuildScope scope;
  SceneData data;
  // The instances' transforms, the re-braid cuts and the wide trees need the
  // nodes, not the triangles: they are made on one thread while the others
  // fill the triangles (the wide collapse, on one thread, took as long as
  // the fill on two on the conference room and the car). The wide trees are
  // part of the bottom level: their time counts in its build time.
  data.blas = build_blas_set(scene, BuildOptions{}, threads, merge, [&](const BlasSet& blas) {
    const size_t n = scene.instances.size();
    data.tree_from_world.resize(n);
    data.renderable.resize(n);
    data.normal_xforms.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const Instance& inst = scene.instances[i];
      const Xform world_from_tree = inst.world_from_object * object_from_tree(blas, inst.mesh);
      // glTF allows a zero scale: such an instance is simply not there.
      const bool invertible = affine_inverse(world_from_tree, &data.tree_from_world[i]);
      // A merged instance is rendered through its group's tree (the same
      // world_from_tree: its tree_from_world and normal matrix are the first
      // member's, bit for bit).
      data.renderable[i] = invertible && blas.instance_roots[blas.traced_by[i]] != RF_INVALID;
      if (invertible) normal_matrix_rows3x3(world_from_tree, data.normal_xforms[i].m);
      if (!invertible) data.hidden_instances++;
      if (!data.renderable[i]) continue;
      data.world_bounds.grow(transform_bounds_conservative(inst.world_from_object, blas.bounds[inst.mesh]));
      double big = 0.0;
      for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r) big = std::max(big, std::fabs(data.tree_from_world[i][c][r]));
      if (big > 0.0 && std::isfinite(big)) data.max_tree_scale = std::max(data.max_tree_scale, std::ilogb(big));
    }
    choose_braid_cuts(scene, blas, data, braid);
    WideTrees wide = build_wide_trees(blas.nodes.data(), blas.nodes.size(), data.braid_nodes);
    data.wide_nodes = std::move(wide.nodes);
    data.braid_wide = std::move(wide.roots);
  });
  data.alpha = build_alpha_tables(scene, data.blas);
  return data;
}

size_t max_tlas_items(const SceneData& data, int groups) {
  return static_cast<size_t>(groups) * data.braid_nodes.size();
}
size_t max_tlas_nodes(const SceneData& data, int groups) { return 2 * max_tlas_items(data, groups) + 2; }

}  // namespace rayfold::core
