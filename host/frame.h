// What changes per frame: camera-space instances, culling, the top-level tree.
// What does not (the bottom-level trees, normal matrices) is SceneData, built
// once per scene.
#pragma once

#include <cstdint>
#include <vector>

#include "blas.h"
#include "camera.h"
#include "culling.h"
#include "device_layout.h"
#include "ray_list.h"
#include "scene.h"

namespace rayfold {

// Partial re-braiding (Benthin, Wald, Woop, Afra 2017): the top-level tree
// is built not over whole instances but over a cut through each instance's
// bottom-level tree, opened largest-first in world space. Meshes grouped by
// material overlap the whole scene; their upper nodes in the top level make it
// a spatial tree again, where near-to-far order stops rays early and culling
// (per fold group) drops the parts of a mesh a quadrant cannot see.
struct BraidOptions {
  bool enabled = true;
  size_t items_per_instance = 2;      // budget: this many items per instance on average...
  size_t min_items = 256;             // ...but at least this many, so scenes of a few big meshes open
  double min_area_fraction = 1e-3;    // never open a node smaller than this share of the scene
};

struct SceneData {
  BlasSet blas;
  // The cut of each instance's tree: braid_nodes[braid_offsets[i] ..
  // braid_offsets[i + 1]) are the BLAS nodes that enter the top level for
  // instance i (just its root when re-braiding is off).
  std::vector<uint32_t> braid_offsets;
  std::vector<uint32_t> braid_nodes;
  std::vector<Xform> tree_from_world;           // per scene instance, into its mesh's tree space
  std::vector<bool> renderable;                 // false: singular transform or empty mesh
  std::vector<rf_normal_xform> normal_xforms;   // per scene instance, tree-space normals to world
  Aabb world_bounds;                            // of the renderable instances at rest
  // The largest ilogb of a tree_from_world linear entry over the renderable
  // instances: how many tree units the smallest instance packs into a world
  // unit, as a power of two (frame.h's trace exponent keeps it in range).
  int max_tree_scale = INT32_MIN;
  size_t hidden_instances = 0;
};

SceneData prepare_scene(const Scene& scene, unsigned threads = 0, const BraidOptions& braid = {});

struct FrameOptions {
  FoldMode fold = FoldMode::none;
  bool cull = true;        // frustum culling before the top-level build
  int animate_frame = -1;  // >= 0: pose of the animated instances (animation.h)
};

struct FrameStats {
  size_t candidates = 0;  // renderable scene instances
  size_t kept = 0;        // instances (mirrored copies included) in the top-level tree
  double cull_ms = 0.0;
  double tlas_ms = 0.0;
  double tlas_sah = 0.0;
  int tlas_depth = 0;
  // Instances not traced because, at this view, their size relative to the
  // distances in view is beyond the float range (a scene mixing sizes more
  // than about 2^160 apart): their transform into trace space would overflow.
  size_t out_of_range = 0;
};

struct Frame {
  // Trace space is camera space in units of 2^trace_exponent: the power of
  // two that brings the eye's largest distance to the scene's bounds into
  // [1, 2), lowered (by up to 2^60) where the smallest instance would
  // otherwise be more than 2^100 of its tree units per trace unit. Both move
  // exactly with the scene, so a scene scaled by 2^k traces the same floats.
  int trace_exponent = 0;
  Xform camera_from_trace{1.0};
  float depth_scale = 1.0f;            // 2^trace_exponent, rf_camera::depth_scale
  uint32_t node_base = 0;              // first TLAS node index in the full node array
  uint32_t tlas_root = RF_INVALID;     // RF_INVALID: nothing to trace
  std::vector<rf_node> tlas_nodes;     // to be placed at node_base
  std::vector<rf_instance> instances;  // in TLAS leaf order
  // Normal matrices of every scene instance when animation moved some this
  // frame; empty when SceneData's still hold.
  std::vector<rf_normal_xform> normal_xforms;
  FrameStats stats;
};

// Culls each scene instance, and for a folded ray list each mirrored copy of
// it, against the frustum of the rays that can meet it, then builds the
// top-level tree over what is left.
Frame build_frame(const Scene& scene, const SceneData& data, const Camera& camera, const RayList& rays,
                  const FrameOptions& options);

// The most top-level items (instances and their mirrored copies) and nodes a
// frame of this scene can need; device buffers are sized by them once.
size_t max_tlas_items(const SceneData& data);
size_t max_tlas_nodes(const SceneData& data);

// The camera's ray parameters as a frame traces them: with its depth scale.
rf_camera frame_camera(const Camera& camera, const Frame& frame);

}  // namespace rayfold
