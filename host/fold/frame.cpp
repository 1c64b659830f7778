#include "fold/frame.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstring>

#include "bvh/bvh_flatten.h"
#include "fold/depth_xform.h"
#include "fold/fold.h"
#include "scene/animation.h"
#include "util/errors.h"
#include "util/timer.h"

namespace rayfold::core {

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
  if (data.max_tree_scale == INT_MIN || data.max_tree_scale + extent <= kTreeFromTraceTarget) return extent;
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

int trace_exponent(const SceneData& data, const Camera& camera) {
  return choose_trace_exponent(data, glm::dvec3(camera.world_from_camera[3]));
}

bool can_align(const SceneData& data, const Camera& a, const Camera& b) {
  if (std::memcmp(&a.params, &b.params, sizeof a.params) != 0) return false;
  return !a.params.ortho || trace_exponent(data, a) == trace_exponent(data, b);
}

int pass_groups(int views, Fold fold) { return views * mirror_slots(fold); }
int max_pass_views(Fold fold) { return RF_GROUP_LIMIT / mirror_slots(fold); }

std::vector<float> Frame::depth_scales() const {
  std::vector<float> out;
  for (const FrameView& v : views) out.push_back(v.depth_scale);
  return out;
}

rf_camera frame_camera(const Camera& camera, const Frame& frame) {
  rf_camera params = camera.params;
  // Orthographic rays start on the image plane at trace-space positions:
  // the pixel spacing in trace units (a power of two apart, exact; the
  // views of a pass share the exponent, can_align).
  if (params.ortho && !frame.views.empty()) {
    params.scale_x = std::ldexp(params.scale_x, -frame.views[0].trace_exponent);
    params.scale_y = std::ldexp(params.scale_y, -frame.views[0].trace_exponent);
  }
  params.views = static_cast<uint32_t>(std::max<size_t>(frame.views.size(), 1));
  params.group_shift = fold_group_shift(frame.fold);
  params.slot_mirrors = fold_slot_mirrors(frame.fold);
  params.view_rep = 0;
  for (uint32_t v = 0; v < params.views; ++v) params.view_rep |= 1u << (v << params.group_shift);
  params.write_flags = (frame.normals ? 0u : RF_WRITE_NO_NORMALS) | (frame.planar_depth ? RF_WRITE_PLANAR_DEPTH : 0u) |
                       (frame.exact_depth ? RF_WRITE_EXACT_DEPTH : 0u);
  return params;
}

Frame build_frame(const Scene& scene, const SceneData& data, const Camera& camera, const RayList& rays,
                  const FrameOptions& options) {
  return build_frame(scene, data, std::vector<Camera>{camera}, rays, options);
}

Frame build_frame(const Scene& scene, const SceneData& data, const std::vector<Camera>& cameras, const RayList& rays,
                  const FrameOptions& options) {
  RF_CHECK(!cameras.empty(), "a frame needs a view");
  RF_CHECK(pass_groups(static_cast<int>(cameras.size()), options.fold) <= RF_GROUP_LIMIT,
           "more (view, mirror) groups than one pass holds");
  Frame frame;
  frame.fold = options.fold;
  frame.normals = options.normals;
  frame.whole_trees = options.whole_trees;
  frame.planar_depth = options.planar_depth;
  frame.exact_depth = options.exact_depth;
  frame.node_base = static_cast<uint32_t>(data.blas.nodes.size());
  std::vector<Xform> world_from_trace, trace_from_world;
  for (const Camera& camera : cameras) {
    RF_CHECK(can_align(data, cameras[0], camera), "views of one pass must share their rays");
    FrameView view;
    view.trace_exponent = trace_exponent(data, camera);
    view.camera_from_trace = uniform_scale(view.trace_exponent);
    view.depth_scale = static_cast<float>(std::ldexp(1.0, view.trace_exponent));
    world_from_trace.push_back(camera.world_from_camera * view.camera_from_trace);
    trace_from_world.push_back(uniform_scale(-view.trace_exponent) * camera.camera_from_world);
    frame.views.push_back(view);
  }
  // The exact depth's table: each view's camera entry, then its instances'
  // (filled below for those traced; the others are never hit).
  const size_t instance_count = scene.instances.size();
  frame.depth_instances = static_cast<uint32_t>(instance_count);
  if (frame.exact_depth) {
    frame.depth_xforms.assign(cameras.size() * (instance_count + 1), rf_depth_xform{});
    for (size_t v = 0; v < cameras.size(); ++v)
      frame.depth_xforms[v * (instance_count + 1)] =
          make_depth_xform(Xform(1.0), cameras[v], frame.views[v].trace_exponent);
  }

  auto t0 = Clock::now();
  const rf_camera traced = frame_camera(cameras[0], frame);
  std::vector<Frustum> frusta;
  for (int m = 0; m < RF_MIRRORS; ++m) frusta.emplace_back(traced, rays.regions[m]);
  const int slots = mirror_slots(options.fold);
  // The largest trace-space ray origin: 0 from the eye; orthographic, the
  // image plane's farthest pixel.
  double plane_x = 0.0, plane_y = 0.0;
  if (traced.ortho) {
    const int kx_far = std::max(std::abs(traced.kx0), std::abs(2 * (traced.width - 1) + traced.kx0));
    const int ky_far = std::max(std::abs(traced.ky0), std::abs(traced.ky0 - 2 * (traced.height - 1)));
    plane_x = std::fabs(double(traced.scale_x)) * (kx_far + 1.0);
    plane_y = std::fabs(double(traced.scale_y)) * (ky_far + 1.0);
  }
  const bool animate = options.animate_frame >= 0;
  std::vector<char> moved;
  if (!options.moved.empty()) {
    moved.assign(scene.instances.size(), 0);
    for (uint32_t i : options.moved) {
      RF_CHECK_LT(i, moved.size(), "moved instance index out of range");
      moved[i] = 1;
    }
  }
  if (animate || !moved.empty()) frame.normal_xforms = data.normal_xforms;
  std::vector<Aabb> boxes;
  std::vector<rf_instance> candidates;
  // Instance i's copies for view v: one per mirror the fold traces, per cut
  // node of its tree, each culled against the rays that can meet it.
  auto add_copies = [&](size_t i, const Xform& tree_from_world, const Xform& world_from_tree, uint32_t v) {
    const Xform trace_from_tree = trace_from_world[v] * world_from_tree;
    rf_instance base{};
    to_rows3x4(tree_from_world * world_from_trace[v], base.tree_from_trace);
    if (!traceable(base.tree_from_trace)) {
      frame.views[v].out_of_range++;
      return;
    }
    if (frame.exact_depth)
      frame.depth_xforms[v * (instance_count + 1) + 1 + i] =
          make_depth_xform(tree_from_world * world_from_trace[v], cameras[v], frame.views[v].trace_exponent);
    // The object-space ray starts at the float-rounded eye (the translation
    // column), up to half an ulp of its coordinates beside the exact one;
    // mapped back to camera space that shift must fit inside the item's box,
    // or the top level could prune the item holding the closest hit in one
    // traversal order and not in another (geometry stored far from its
    // origin, docs/exactness.md).
    double origin = 0.0, stretch = 0.0;
    for (int r = 0; r < 3; ++r) {
      // Orthographic origins go through the transform too (the rounding of
      // m0 * ox + m1 * oy + m3 is within 2^-22 of its terms' sum).
      // Ray queries start anywhere within query_origin_bound.
      const double q = options.query_origin_bound;
      origin = std::max(origin, std::fabs(double(base.tree_from_trace[4 * r + 3])) +
                                    std::fabs(double(base.tree_from_trace[4 * r])) * (plane_x + q) +
                                    std::fabs(double(base.tree_from_trace[4 * r + 1])) * (plane_y + q) +
                                    std::fabs(double(base.tree_from_trace[4 * r + 2])) * q);
      stretch = std::max(stretch, std::fabs(trace_from_tree[0][r]) + std::fabs(trace_from_tree[1][r]) +
                                      std::fabs(trace_from_tree[2][r]));
    }
    const double origin_pad = origin * stretch * 0x1p-22;
    base.instance_id = static_cast<uint32_t>(i);
    const uint32_t whole_root = data.blas.instance_roots[i];  // RF_INVALID for a merged tree's later members
    const uint32_t cut_end = options.whole_trees ? (whole_root != RF_INVALID ? 1u : 0u)
                                                 : data.braid_offsets[i + 1] - data.braid_offsets[i];
    for (uint32_t k = 0; k < cut_end; ++k) {
      const uint32_t c = data.braid_offsets[i] + k;
      const uint32_t cut = options.whole_trees ? whole_root : data.braid_nodes[c];
      const rf_node& node = data.blas.nodes[cut];
      Aabb tree_box;
      tree_box.grow(glm::vec3(node.bmin[0], node.bmin[1], node.bmin[2]));
      tree_box.grow(glm::vec3(node.bmax[0], node.bmax[1], node.bmax[2]));
      const Aabb box = transform_bounds_conservative(trace_from_tree, tree_box, origin_pad);
      base.blas_root = cut;
      base.wide_root = options.whole_trees ? RF_INVALID : data.braid_wide[c];
      for (int slot = 0; slot < slots; ++slot) {
        const int m = slot_mirror(options.fold, slot);
        if (!rays.group_used[m]) continue;
        const Aabb mirrored = mirror_box(box, m);
        if (options.cull && !frusta[m].may_see(mirrored)) continue;
        rf_instance out = base;
        mirror_columns(out.tree_from_trace, m);
        out.group = v * static_cast<uint32_t>(slots) + static_cast<uint32_t>(slot);
        candidates.push_back(out);
        boxes.push_back(mirrored);
      }
    }
  };
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    if (!data.renderable[i]) continue;
    frame.stats.candidates++;
    const Instance& inst = scene.instances[i];
    Xform world_from_tree = inst.world_from_object * object_from_tree(data.blas, inst.mesh);
    Xform tree_from_world = data.tree_from_world[i];
    // A merged tree moves only as a whole: instances that move are built
    // dynamic (MergeOptions), or the trees are built again.
    if ((animate && is_animated(i)) || (!moved.empty() && moved[i]))
      RF_CHECK(!data.blas.merged[i], "instance " + std::to_string(i) + " moves but was merged");
    if (animate && is_animated(i)) {
      world_from_tree = animated_world_from_object(inst, data.blas.bounds[inst.mesh], i, options.animate_frame) *
                        object_from_tree(data.blas, inst.mesh);
      const bool ok = affine_inverse(world_from_tree, &tree_from_world);
      RF_CHECK(ok, "animation made a transform singular");
      normal_matrix_rows3x3(world_from_tree, frame.normal_xforms[i].m);
    } else if (!moved.empty() && moved[i]) {
      if (!affine_inverse(world_from_tree, &tree_from_world)) continue;
      normal_matrix_rows3x3(world_from_tree, frame.normal_xforms[i].m);
    }
    for (uint32_t v = 0; v < cameras.size(); ++v) add_copies(i, tree_from_world, world_from_tree, v);
  }
  frame.stats.kept = candidates.size();
  frame.stats.cull_ms = ms_since(t0);

  t0 = Clock::now();
  BuildOptions tlas_options;
  tlas_options.max_leaf_size = 4;
  tlas_options.intersection_cost = 2.0f;  // an instance costs a ray transform on top of its root test
  tlas_options.pair_primitives = false;  // its leaf costs were tuned on unpaired trees; pairs there are unmeasured
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

}  // namespace rayfold::core
