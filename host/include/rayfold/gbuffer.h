// The G-buffer of one render: eight channels per pixel in planes, rows from
// the top.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rayfold/types.h"

namespace rayfold {

// How the screen is folded: y mirrors about the camera's vertical plane
// (pairs columns), x about the horizontal plane (pairs rows), xy both. The
// output is bit for bit the same in every mode; only the work differs.
enum class Fold { none, y, x, xy };

// "none", "y", "x" or "xy", as the CLI's --fold and Python's fold= spell them.
inline const char* fold_name(Fold f) {
  switch (f) {
    case Fold::y: return "y";
    case Fold::x: return "x";
    case Fold::xy: return "xy";
    default: return "none";
  }
}

// The channels a render fills, as bit flags (kAllChannels by default): a
// job that needs depth and masks asks for kDepth | kInstanceId and gets the
// other planes empty, skipping their copies.
enum Channels : unsigned {
  kDepth = 1u,
  kNormal = 2u,
  kUv = 4u,
  kInstanceId = 8u,
  kPrimitiveId = 16u,
  kAllChannels = 31u,
};

// What a G-buffer's depth plane holds.
enum class Depth {
  distance,  // along the pixel's ray from the eye (Camera::ray_direction)
  planar,    // along the camera's axis (camera-space -z; Nuke's and Blender's Z, a NeRF's depth map)
};

// Where a render's time went, stage by stage, in ms on the host's clock (a
// trace of several views: the whole pass's, shared by its views).
struct StageTimes {
  double cull_ms = 0.0;      // instances outside the view left out
  double tlas_ms = 0.0;      // the top-level tree over the rest
  double upload_ms = 0.0;    // its nodes and instances to the device
  double ray_list_ms = 0.0;  // the compacted ray list; 0 when the last render's still holds
  double trace_ms = 0.0;     // the kernel
  double readback_ms = 0.0;  // the hits or planes back from the device
};

// The top-level tree a render traced.
struct TopLevelStats {
  size_t scene_instances = 0;   // instances the scene renders (not hidden, not empty)
  size_t traced_instances = 0;  // in the tree, after culling: copies per view and per mirror included
  size_t out_of_range = 0;      // instances beyond the float range at this view (and in `warnings`)
  double sah_cost = 0.0;        // the tree's surface-area cost
};

struct GBuffer {
  int width = 0, height = 0;
  // Distance from the eye along the pixel's ray (Camera::ray_direction), in
  // world units; +inf on a miss. height * width.
  std::vector<float> depth;
  // World-space geometric normal, unit length, on the side the triangle's
  // winding makes its front (the file's, also under mirroring transforms);
  // 0 on a miss. height * width * 3.
  std::vector<float> normal;
  // Barycentric weights of the triangle's second and third vertex; 0 on a
  // miss. height * width * 2.
  std::vector<float> uv;
  std::vector<uint32_t> instance_id;   // Scene instance index, kMiss on a miss
  std::vector<uint32_t> primitive_id;  // triangle index within the mesh, kMiss on a miss
  unsigned channels = kAllChannels;    // the planes filled (Channels); the others are empty
  Depth depth_kind = Depth::distance;  // what `depth` measures (RendererOptions::depth)
  bool exact_depth = false;            // depth from the exact ray in double-float (RendererOptions::exact_depth)

  Fold fold = Fold::none;  // the fold traced (one the camera allows; Camera::can_fold_columns)
  size_t rays = 0;         // rays traced
  size_t hits = 0;         // pixels that hit
  double trace_ms = 0.0;   // on the device (a trace of several views: its share)
  double frame_ms = 0.0;   // culling, top-level build, upload, ray list, trace, readback (likewise)
  int views_in_trace = 1;  // views traced together with this one, itself included (Renderer::render_views)
  StageTimes stages;       // trace_ms's and the other stages' times (likewise the pass's)
  TopLevelStats top_level;
  // The kernel that traced it ("tile", "single", "cpu reference") and why
  // ("CPU device", "chosen", "measured on the first frame: ...").
  std::string kernel, kernel_reason;
  // What this render may have lost, in words (docs/exactness.md); empty
  // within rayfold's exact range.
  std::vector<std::string> warnings;
};

}  // namespace rayfold
