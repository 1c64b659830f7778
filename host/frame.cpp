#include "frame.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <queue>

#include "animation.h"
#include "bvh_flatten.h"
#include "errors.h"

namespace rayfold {
namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

// Mirroring camera x (or y) is exact: negate the coordinate and swap ends.
Aabb mirror_box(const Aabb& b, int group) {
  Aabb m = b;
  if (group_mirrors_x(group)) {
    m.lo.x = -b.hi.x;
    m.hi.x = -b.lo.x;
  }
  if (group_mirrors_y(group)) {
    m.lo.y = -b.hi.y;
    m.hi.y = -b.lo.y;
  }
  return m;
}

// tree_from_trace of a mirrored copy: the original times the mirror,
// i.e. the x (or y) column negated. A traced ray then reaches object space
// bit-identical to the partner pixel's ray through the original.
void mirror_columns(float rows[12], int group) {
  for (int r = 0; r < 3; ++r) {
    if (group_mirrors_x(group)) rows[4 * r + 0] = -rows[4 * r + 0];
    if (group_mirrors_y(group)) rows[4 * r + 1] = -rows[4 * r + 1];
  }
}

// In double: world-space areas of float boxes overflow a float from about
// 1e19 on, and the braid must choose the same cut at every scale.
double half_area(const Aabb& b) {
  if (b.empty()) return 0.0;
  const glm::dvec3 e = glm::dvec3(b.hi) - glm::dvec3(b.lo);
  return e.x * e.y + e.y * e.z + e.z * e.x;
}

// Opens the largest (in world space) BLAS nodes of all instances until the
// budget is spent; the open frontier is each instance's cut.
void choose_braid_cuts(const Scene& scene, SceneData& data, const BraidOptions& opt) {
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
    b.grow(glm::vec3(data.blas.nodes[node].bmin[0], data.blas.nodes[node].bmin[1], data.blas.nodes[node].bmin[2]));
    b.grow(glm::vec3(data.blas.nodes[node].bmax[0], data.blas.nodes[node].bmax[1], data.blas.nodes[node].bmax[2]));
    const Instance& inst = scene.instances[i];
    return half_area(transform_bounds_conservative(inst.world_from_object * object_from_tree(data.blas, inst.mesh), b));
  };
  size_t items = 0;
  for (uint32_t i = 0; i < n; ++i) {
    if (!data.renderable[i]) continue;
    open.push({world_area(i, data.blas.roots[scene.instances[i].mesh]), i, data.blas.roots[scene.instances[i].mesh]});
    ++items;
  }
  if (opt.enabled) {
    const size_t budget = std::max(opt.min_items, opt.items_per_instance * items);
    const double min_area = opt.min_area_fraction * half_area(data.world_bounds);
    while (!open.empty() && items < budget && open.top().area >= min_area) {
      const Item top = open.top();
      const rf_node& node = data.blas.nodes[top.node];
      if ((node.meta & RF_NODE_COUNT_MASK) != 0) {  // a leaf cannot open
        cuts[top.instance].push_back(top.node);
        open.pop();
        continue;
      }
      open.pop();
      open.push({world_area(top.instance, node.first), top.instance, node.first});
      open.push({world_area(top.instance, node.first + 1), top.instance, node.first + 1});
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

SceneData prepare_scene(const Scene& scene, unsigned threads, const BraidOptions& braid) {
  check_world_range(scene, "");
  SceneData data;
  data.blas = build_blas_set(scene, BuildOptions{}, threads);
  const size_t n = scene.instances.size();
  data.tree_from_world.resize(n);
  data.renderable.resize(n);
  data.normal_xforms.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const Instance& inst = scene.instances[i];
    const Xform world_from_tree = inst.world_from_object * object_from_tree(data.blas, inst.mesh);
    // glTF allows a zero scale: such an instance is simply not there.
    const bool invertible = affine_inverse(world_from_tree, &data.tree_from_world[i]);
    data.renderable[i] = invertible && data.blas.roots[inst.mesh] != RF_INVALID;
    if (invertible) normal_matrix_rows3x3(world_from_tree, data.normal_xforms[i].m);
    if (!invertible) data.hidden_instances++;
    if (!data.renderable[i]) continue;
    data.world_bounds.grow(transform_bounds_conservative(inst.world_from_object, data.blas.bounds[inst.mesh]));
    double big = 0.0;
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) big = std::max(big, std::fabs(data.tree_from_world[i][c][r]));
    if (big > 0.0 && std::isfinite(big)) data.max_tree_scale = std::max(data.max_tree_scale, std::ilogb(big));
  }
  choose_braid_cuts(scene, data, braid);
  return data;
}

size_t max_tlas_items(const SceneData& data) { return RF_MAX_GROUPS * data.braid_nodes.size(); }
size_t max_tlas_nodes(const SceneData& data) { return 2 * max_tlas_items(data) + 2; }

rf_camera frame_camera(const Camera& camera, const Frame& frame) {
  rf_camera params = camera.params;
  params.depth_scale = frame.depth_scale;
  return params;
}

namespace {

// Limits of trace space, as powers of two: the largest tree_from_trace
// entry aimed for, how far below the scene's extent the trace unit may go to
// reach it (trace-space boxes up to 2^60 keep the builder's float areas
// finite), and the largest entry traced at all (a ray direction of up to
// 2^7, a 179-degree view, stays finite).
constexpr int kTreeFromTraceTarget = 100;
constexpr int kTraceBelowExtent = 60;
constexpr int kTreeFromTraceLimit = 118;

// The eye's largest distance (per axis) to the scene's bounds, as a power of
// two, lowered for the smallest instance (Frame::trace_exponent). Powers of
// two move exactly with the scene: a scene and eye scaled by 2^k give
// trace_exponent + k.
int choose_trace_exponent(const SceneData& data, const glm::dvec3& eye) {
  const Aabb& b = data.world_bounds;
  if (b.empty()) return 0;
  double far = 0.0;
  for (int k = 0; k < 3; ++k)
    far = std::max({far, std::fabs(double(b.lo[k]) - eye[k]), std::fabs(double(b.hi[k]) - eye[k])});
  const int extent = far > 0.0 && std::isfinite(far) ? std::ilogb(far) : 0;
  if (data.max_tree_scale == INT32_MIN || data.max_tree_scale + extent <= kTreeFromTraceTarget) return extent;
  return std::max(extent - kTraceBelowExtent, kTreeFromTraceTarget - data.max_tree_scale);
}

// Whether an instance's float tree_from_trace can be traced: finite, with
// ray directions that cannot overflow.
bool traceable(const float m[12]) {
  for (int i = 0; i < 12; ++i)
    if (!std::isfinite(m[i]) || (i % 4 != 3 && std::fabs(m[i]) > std::ldexp(1.0f, kTreeFromTraceLimit))) return false;
  return true;
}

}  // namespace

Frame build_frame(const Scene& scene, const SceneData& data, const Camera& camera, const RayList& rays,
                  const FrameOptions& options) {
  Frame frame;
  frame.node_base = static_cast<uint32_t>(data.blas.nodes.size());
  frame.trace_exponent = choose_trace_exponent(data, glm::dvec3(camera.world_from_camera[3]));
  frame.camera_from_trace = uniform_scale(frame.trace_exponent);
  frame.depth_scale = static_cast<float>(std::ldexp(1.0, frame.trace_exponent));
  const Xform world_from_trace = camera.world_from_camera * frame.camera_from_trace;
  const Xform trace_from_world = uniform_scale(-frame.trace_exponent) * camera.camera_from_world;

  auto t0 = std::chrono::steady_clock::now();
  std::vector<Frustum> frusta;
  for (int g = 0; g < RF_MAX_GROUPS; ++g) frusta.emplace_back(camera.params, rays.regions[g]);
  const bool animate = options.animate_frame >= 0;
  if (animate) frame.normal_xforms = data.normal_xforms;
  std::vector<Aabb> boxes;
  std::vector<rf_instance> candidates;
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    if (!data.renderable[i]) continue;
    frame.stats.candidates++;
    const Instance& inst = scene.instances[i];
    Xform world_from_tree = inst.world_from_object * object_from_tree(data.blas, inst.mesh);
    Xform tree_from_world = data.tree_from_world[i];
    if (animate && is_animated(i)) {
      world_from_tree = animated_world_from_object(inst, data.blas.bounds[inst.mesh], i, options.animate_frame) *
                        object_from_tree(data.blas, inst.mesh);
      const bool ok = affine_inverse(world_from_tree, &tree_from_world);
      RF_CHECK(ok, "animation made a transform singular");
      normal_matrix_rows3x3(world_from_tree, frame.normal_xforms[i].m);
    }
    const Xform trace_from_tree = trace_from_world * world_from_tree;
    rf_instance base{};
    to_rows3x4(tree_from_world * world_from_trace, base.tree_from_trace);
    if (!traceable(base.tree_from_trace)) {
      frame.stats.out_of_range++;
      continue;
    }
    // The object-space ray starts at the float-rounded eye (the translation
    // column), up to half an ulp of its coordinates beside the exact one;
    // mapped back to camera space that shift must fit inside the item's box,
    // or the top level could prune the item holding the closest hit in one
    // traversal order and not in another (geometry stored far from its
    // origin, docs/exactness.md).
    double origin = 0.0, stretch = 0.0;
    for (int r = 0; r < 3; ++r) {
      origin = std::max(origin, static_cast<double>(std::fabs(base.tree_from_trace[4 * r + 3])));
      stretch = std::max(stretch, std::fabs(trace_from_tree[0][r]) + std::fabs(trace_from_tree[1][r]) +
                                      std::fabs(trace_from_tree[2][r]));
    }
    const double origin_pad = origin * stretch * 0x1p-22;
    base.instance_id = static_cast<uint32_t>(i);
    for (uint32_t c = data.braid_offsets[i]; c < data.braid_offsets[i + 1]; ++c) {
      const rf_node& node = data.blas.nodes[data.braid_nodes[c]];
      Aabb tree_box;
      tree_box.grow(glm::vec3(node.bmin[0], node.bmin[1], node.bmin[2]));
      tree_box.grow(glm::vec3(node.bmax[0], node.bmax[1], node.bmax[2]));
      const Aabb box = transform_bounds_conservative(trace_from_tree, tree_box, origin_pad);
      base.blas_root = data.braid_nodes[c];
      for (int g = 0; g < RF_MAX_GROUPS; ++g) {
        if (!rays.group_used[g]) continue;
        const Aabb mirrored = mirror_box(box, g);
        if (options.cull && !frusta[g].may_see(mirrored)) continue;
        rf_instance out = base;
        mirror_columns(out.tree_from_trace, g);
        out.group = static_cast<uint32_t>(g);
        candidates.push_back(out);
        boxes.push_back(mirrored);
      }
    }
  }
  frame.stats.kept = candidates.size();
  frame.stats.cull_ms = ms_since(t0);

  t0 = std::chrono::steady_clock::now();
  BuildOptions tlas_options;
  tlas_options.max_leaf_size = 4;
  tlas_options.intersection_cost = 2.0f;  // an instance costs a ray transform on top of its root test
  const BuildTree tree = build_sah(boxes, tlas_options);
  frame.instances.reserve(tree.order.size());
  std::vector<uint32_t> groups;
  groups.reserve(tree.order.size());
  for (uint32_t k : tree.order) {
    frame.instances.push_back(candidates[k]);
    groups.push_back(1u << candidates[k].group);
  }
  frame.tlas_root = flatten_bvh(tree, 0, &groups, frame.node_base, frame.tlas_nodes);
  frame.stats.tlas_ms = ms_since(t0);
  frame.stats.tlas_sah = tree.sah_cost;
  frame.stats.tlas_depth = tree.depth;
  return frame;
}

}  // namespace rayfold
