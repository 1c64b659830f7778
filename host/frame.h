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

struct SceneData {
  BlasSet blas;
  std::vector<Xform> object_from_world;         // per scene instance
  std::vector<bool> renderable;                 // false: singular transform or empty mesh
  std::vector<rf_normal_xform> normal_xforms;   // per scene instance
  size_t hidden_instances = 0;
};

SceneData prepare_scene(const Scene& scene, unsigned threads = 0);

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
};

struct Frame {
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

// The most top-level nodes a frame of this scene can need; device buffers are
// sized by it once.
size_t max_tlas_nodes(const Scene& scene);

}  // namespace rayfold
