// What changes per frame: trace space, the instances and their mirrored
// copies in it, culling, the top-level tree. What does not (the bottom-level
// trees, normal matrices) is SceneData (bvh/scene_data.h), built once per
// scene.
#pragma once

#include <cstdint>
#include <vector>

#include "bvh/scene_data.h"
#include "device_layout.h"
#include "fold/culling.h"
#include "fold/fold.h"
#include "fold/ray_list.h"
#include "util/page_aligned.h"
#include "scene/camera.h"
#include "scene/scene.h"

namespace rayfold::core {

// One view's G-buffer planes in host memory, for the kernels to write in
// place (rf_answers): each null where not asked for.
struct AnswerPlanes {
  float* z = nullptr;       // 1 a pixel
  float* normal = nullptr;  // 3 a pixel
  float* uv = nullptr;      // 2 a pixel
  uint32_t* instance = nullptr;
  uint32_t* primitive = nullptr;
};

struct FrameOptions {
  Fold fold = Fold::none;
  bool cull = true;        // frustum culling before the top-level build
  int animate_frame = -1;  // >= 0: pose of the animated instances (animation.h)
  // Scene instances whose world_from_object changed since prepare_scene: their
  // tree_from_world and normal matrix are computed again from the scene. A
  // moved transform that is singular hides the instance for the frame.
  std::vector<uint32_t> moved{};
  bool normals = true;         // false: the kernels write zero normals (RF_WRITE_NO_NORMALS)
  bool planar_depth = false;  // true: z along the camera's axis (RF_WRITE_PLANAR_DEPTH)
  // true: z from the pixel's exact ray and the hit triangle's plane in
  // double-float, rounded once (RF_WRITE_EXACT_DEPTH, kernels/rf_depth.h);
  // false: from the traversal's float t.
  bool exact_depth = false;
  // The caller takes the planes `channels` (RF_PLANE_*) names packed
  // (RenderResult::planes) where the renderer reads them back so
  // (Pipeline::packs_planes); otherwise every pixel's hit info (hits).
  bool planes = false;
  unsigned channels = RF_PLANE_ALL;
  // With `planes`, a pass of one view on a device that writes host memory
  // (a CPU device) has the kernel write its planes here, in place
  // (RenderResult::planes_in_place): the host's pass from 32-byte hits to
  // planes goes. Elsewhere `planes` alone decides.
  const AnswerPlanes* planes_in_place = nullptr;
  // Ray queries (rays/ray_queries.h): the largest coordinate of a ray
  // origin, in trace units (0: camera rays, from the eye or, orthographic,
  // the image plane); the top level's boxes leave room for its rounding.
  double query_origin_bound = 0.0;
  // Each instance enters the top level as its whole tree (BlasSet::
  // instance_roots) rather than its re-braided cut, with no 4-wide root:
  // for the single-ray query kernel, which walks 8-wide trees collapsed
  // from those roots (rays/ray_queries.h, build_query_trees). Re-braiding
  // serves culling and a camera's tiles; a scattered ray entering one
  // instance through two cuts paid a second set-up and a top-level walk.
  bool whole_trees = false;
};

struct FrameStats {
  size_t candidates = 0;  // renderable scene instances
  size_t kept = 0;        // instances (copies per view and mirror included) in the top-level tree
  double cull_ms = 0.0;
  double tlas_ms = 0.0;
  double tlas_sah = 0.0;
  int tlas_depth = 0;
};

// One view's trace space. Trace space is camera space in units of
// 2^trace_exponent: the power of two that brings the eye's largest distance
// to the scene's bounds into [1, 2), lowered (by up to 2^60) where the
// smallest instance would otherwise be more than 2^100 of its tree units per
// trace unit. Both move exactly with the scene, so a scene scaled by 2^k
// traces the same floats. Each view of a pass keeps the space it has when
// traced alone, so its copies carry exactly the transforms (and its hits
// exactly the bits) of that trace.
struct FrameView {
  int trace_exponent = 0;
  Xform camera_from_trace{1.0};
  float depth_scale = 1.0f;  // 2^trace_exponent
  // Instances not traced because, at this view, their size relative to the
  // distances in view is beyond the float range (a scene mixing sizes more
  // than about 2^160 apart): their transform into trace space would overflow.
  size_t out_of_range = 0;
};

struct Frame {
  std::vector<FrameView> views;  // the views traced together, in pass order
  Fold fold = Fold::none;
  uint32_t node_base = 0;           // first TLAS node index in the full node array
  uint32_t tlas_root = RF_INVALID;  // RF_INVALID: nothing to trace
  std::vector<rf_node> tlas_nodes;  // to be placed at node_base
  // A whole-tree query frame's top level as 8-wide nodes (build_wide8_tlas;
  // the single-ray query kernel's): empty and RF_INVALID elsewhere, and
  // where the root is a leaf. query: made by build_query_frame (the query kernel
  // reads tlas_wide_root only from such a frame). query_wide_roots: per
  // instance, the 8-wide node of its blas_root's children in the query
  // trees build_query_frame was given (RF_INVALID: blas_root is a leaf).
  bool query = false;
  bool whole_trees = false;  // FrameOptions::whole_trees
  PageAlignedVector<rf_wide8_node> tlas_wide;
  uint32_t tlas_wide_root = RF_INVALID;
  std::vector<uint32_t> query_wide_roots;
  std::vector<rf_instance> instances;  // in TLAS leaf order
  bool normals = true;                 // FrameOptions::normals
  bool planar_depth = false;           // FrameOptions::planar_depth
  bool exact_depth = false;            // FrameOptions::exact_depth
  // Normal matrices of every scene instance when animation moved some this
  // frame; empty when SceneData's still hold.
  std::vector<rf_normal_xform> normal_xforms;
  // The exact depth's rays (rf_depth_xform), view after view: the view's
  // camera entry, then one per scene instance (depth_instances of them).
  std::vector<rf_depth_xform> depth_xforms;
  uint32_t depth_instances = 0;
  FrameStats stats;

  // One depth scale per view, as the kernels read them.
  std::vector<float> depth_scales() const;
};

// Culls each scene instance's copy for every view, and for a folded ray list
// every mirrored copy, against the frustum of the rays that can meet it,
// then builds one top-level tree over what is left. The cameras must be
// alignable (can_align) and the rays made for the first one's parameters;
// at most RF_GROUP_LIMIT (view, mirror) groups.
Frame build_frame(const Scene& scene, const SceneData& data, const std::vector<Camera>& cameras, const RayList& rays,
                  const FrameOptions& options);
// One view.
Frame build_frame(const Scene& scene, const SceneData& data, const Camera& camera, const RayList& rays,
                  const FrameOptions& options);

// The view's trace exponent (FrameView) for this scene.
int trace_exponent(const SceneData& data, const Camera& camera);

// Whether two views can be traced together: the same rays, i.e. the same
// intrinsics and image (and, orthographic, the same trace exponent, since
// their rays start at trace-space positions).
bool can_align(const SceneData& data, const Camera& a, const Camera& b);

// The (view, mirror) groups a pass of `views` views folded by `fold` uses.
int pass_groups(int views, Fold fold);
// The most views one pass can trace with this fold (RF_GROUP_LIMIT groups).
int max_pass_views(Fold fold);

// The ray parameters and pass layout (rf_camera) as a frame traces them.
rf_camera frame_camera(const Camera& camera, const Frame& frame);

}  // namespace rayfold::core
