// Renders G-buffers of a scene: the bottom-level trees and kernels once,
// then per render culling, the top-level tree and the trace.
#pragma once

#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rayfold/camera.h"
#include "rayfold/gbuffer.h"
#include "rayfold/scene.h"

namespace rayfold {
namespace core {
class OpenClPreload;
}

struct RendererOptions {
  Backend backend = Backend::opencl;
  // The first OpenCL device whose platform or name contains this (any
  // case); "cpu" or "gpu": the first of that type; "": the first GPU, else
  // the first device (RAYFOLD_CL_DEVICE when set).
  std::string device;
  Kernel kernel = Kernel::automatic;
  unsigned threads = 0;  // host threads for tree builds and the CPU backend; 0: all cores
  Depth depth = Depth::distance;  // planar: one rounding of the ray parameter, in every tracer
  // true: each depth from the pixel's exact ray and the hit triangle's plane
  // in double-float, rounded once: within 2^-24 of the exact value where the
  // float ray's is off by up to 1e-4 on grazing pixels (docs/results.md);
  // about 1.2x to 1.5x the frame time on a CPU. The other channels and the
  // bits on every backend are unchanged.
  bool exact_depth = false;

  // How the work is arranged; the bits are the same whatever they are (the
  // CLI's --braid, --no-merge, --no-cull).
  int braid = 2;  // the top level opens each traced instance's tree into about this many items; 0: whole trees
  bool merge_static = true;  // static instances that share a transform share one tree
  bool cull = true;          // instances outside the view stay out of the top-level tree
  // Fast-math kernels (the CLI's --fast): faster on some devices, NOT bit
  // for bit the CPU reference's, and refused with exact_depth (InputError).
  bool fast_math = false;
};

// One way of tracing a list of views and the cost model's prediction for it
// (docs/cost_model.md), per view.
struct Prediction {
  Fold fold = Fold::none;
  std::string kernel;  // "tile", "single" or "cpu reference"
  int align = 1;       // views per pass
  std::string name;    // "xy/tile/align 8"
  double trace_ms = 0.0;
  double update_ms = 0.0;  // culling, top-level build and upload
  double total_ms() const { return trace_ms + update_ms; }
};

// Renderer::choose_fastest's answer: the choice of least predicted time,
// and every prediction, fastest first.
struct AutoChoice {
  Fold fold = Fold::none;
  int align = 1;
  std::string kernel;
  std::vector<Prediction> predictions;
  double probe_ms = 0.0;  // what predicting cost, all choices together
};

// The bottom-level trees a renderer traces and the kernels it built.
struct BuildStats {
  double trees_ms = 0.0;    // their build (as first built, also when shared from another renderer or a scene file)
  double sah_cost = 0.0;    // their surface-area cost
  int depth = 0;            // the deepest tree's levels
  double kernels_ms = 0.0;  // the OpenCL programs' build (cached on disk after a device's first use); 0 on the CPU
  size_t builds = 0;        // how often this renderer built trees (a scene changed shape: set_time of a skin, add_mesh)
};

// The answers to ray queries (Renderer::intersect), ray by ray.
struct RayHits {
  std::vector<float> t;                 // ray parameter along the given direction (not normalised); +inf on a miss
  std::vector<float> normal;            // 3 per ray: world-space geometric normal as GBuffer's; 0 on a miss
  std::vector<float> uv;                // 2 per ray: barycentrics of the second and third vertex; 0 on a miss
  std::vector<uint32_t> instance_id;    // Scene instance index, kMiss on a miss
  std::vector<uint32_t> primitive_id;   // triangle index within the mesh, kMiss on a miss
  // What the answers may have lost, in words (as GBuffer::warnings): empty
  // within rayfold's exact range.
  std::vector<std::string> warnings;
  unsigned channels = 0;  // the planes filled (Channels, kDepth for t; none until a query fills them)
};

// The view a render's flow goes to (kFlow, kFlowVisible): its camera, and
// the time the scene is posed at for it (seconds, as Scene::set_time; NaN:
// the scene's pose now, a second camera on the same scene).
struct FlowTo {
  Camera camera;
  double time = std::numeric_limits<double>::quiet_NaN();
};

// The most views one trace answers unfolded (32 transform groups).
constexpr int kMaxAlignedViews = 32;

class Renderer {
 public:
  // Builds every mesh's tree and, for OpenCL, the kernels. Throws
  // RuntimeFailure when no OpenCL device matches or a kernel does not build,
  // InputError when the scene reaches beyond world coordinates of 2^126.
  explicit Renderer(const Scene& scene, const RendererOptions& options = {});
  ~Renderer();
  Renderer(Renderer&&) noexcept;
  Renderer& operator=(Renderer&&) noexcept;

  // Traces one view. Instances moved since the last render (Scene::
  // set_transform) are placed anew; meshes or instances added rebuild the
  // trees. Not safe to call from two threads at once.
  // channels (Channels) names the planes filled; InputError for none or an
  // unknown bit.
  GBuffer render(const Camera& camera, Fold fold = Fold::none, unsigned channels = kAllChannels);
  // The same into `out`, reusing its planes when the size matches.
  void render_into(GBuffer& out, const Camera& camera, Fold fold = Fold::none, unsigned channels = kAllChannels);
  // The same with the flow to another view: channels may name kFlow and
  // kFlowVisible (the others refuse them). With to.time set the scene is
  // posed at that time for the flow, then put back as it was (render_at);
  // InputError for a scene without a file, or a pose whose triangles differ.
  GBuffer render(const Camera& camera, Fold fold, unsigned channels, const FlowTo& to);
  void render_into(GBuffer& out, const Camera& camera, Fold fold, unsigned channels, const FlowTo& to);
  // The same with the scene posed at `time` (seconds, as Scene::set_time;
  // NaN: the rest pose) for this render alone: put back as it was after it,
  // set_transform's moves and added instances too. `to`: the flow's view, or
  // null.
  GBuffer render_at(double time, const Camera& camera, Fold fold = Fold::none, unsigned channels = kAllChannels,
                    const FlowTo* to = nullptr);
  void render_into_at(GBuffer& out, double time, const Camera& camera, Fold fold, unsigned channels,
                      const FlowTo* to = nullptr);
  // Traces several views, one GBuffer each in the same order. Views with the
  // same image size and intrinsics are traced together, up to `align` per
  // trace (alignment: one traversal answers every view of it); each view's
  // bits are those of render(view) alone. align 1 traces each alone, 0 as
  // many as one trace holds (kMaxAlignedViews, divided by the fold's
  // mirrors: 2 for y or x, 4 for xy). InputError for another align. With
  // kFlow or kFlowVisible, each view's flow goes to the next view of the
  // list (its forward flow; the list reversed gives the backward flow), the
  // last view's is NaN and flow_visible 0 where it hits (no view follows).
  std::vector<GBuffer> render_views(const std::vector<Camera>& cameras, Fold fold = Fold::none, int align = 0,
                                    unsigned channels = kAllChannels);
  // The same, handing each view to on_view (its index in cameras, its
  // G-buffer) as soon as its trace is done, so that memory holds one trace's
  // views whatever the list's length. Views come trace by trace, in list
  // order within a trace, the traces ordered by their first view: a list of
  // one size and intrinsics comes in list order. An exception from on_view
  // stops the rendering and propagates.
  void render_views(const std::vector<Camera>& cameras, const std::function<void(size_t, GBuffer&&)>& on_view,
                    Fold fold = Fold::none, int align = 0, unsigned channels = kAllChannels);
  // The same, prepare getting each view's index and its empty GBuffer before
  // it is filled: planes it sizes for the view (the memory of G-buffers
  // already handled) are written over in place, as render_into does, sparing
  // fresh memory's page faults (at 720p, all channels, about as long as the
  // trace on a 2-core CPU).
  void render_views(const std::vector<Camera>& cameras, const std::function<void(size_t, GBuffer&&)>& on_view,
                    Fold fold, int align, unsigned channels, const std::function<void(size_t, GBuffer&)>& prepare);

  // The closest hit of each of n world-space rays with tmin < t <= tmax:
  // origins and directions are n x 3 floats, row-major; t is along the
  // direction as given. The same triangle test and tie rule as a render, on
  // every backend the same bits; rays of any number, in bounded memory.
  // InputError naming the first bad ray (a coordinate not finite, a zero
  // direction) or for tmin, tmax outside 0 <= tmin <= tmax (tmax may be
  // +inf). Not safe to call from two threads at once. Consecutive rays
  // from one origin trace together in vector lanes (the same bits); with
  // row_length, the rays are an image's rows of that many pixels (row-major,
  // n a multiple of it), traced in 16x16 blocks: faster for camera rays.
  // channels (Channels; kDepth names t) the planes filled, the others left
  // empty, and without kNormal no normal is computed; InputError for none or
  // an unknown bit.
  RayHits intersect(const float* origins, const float* directions, size_t n, float tmin = 0.0f,
                    float tmax = std::numeric_limits<float>::infinity(), size_t row_length = 0,
                    unsigned channels = kAllChannels);
  // The same into `out`, reusing its planes when the size matches (after an
  // exception, what they hold is unspecified).
  void intersect_into(RayHits& out, const float* origins, const float* directions, size_t n, float tmin = 0.0f,
                      float tmax = std::numeric_limits<float>::infinity(), size_t row_length = 0,
                      unsigned channels = kAllChannels);
  // Whether each ray has any hit with tmin < t <= tmax (1) or none (0); each
  // ray stops at the first hit it finds. Inputs as intersect; warnings, when
  // given, receives RayHits::warnings.
  std::vector<uint8_t> occluded(const float* origins, const float* directions, size_t n, float tmin = 0.0f,
                                float tmax = std::numeric_limits<float>::infinity(),
                                std::vector<std::string>* warnings = nullptr, size_t row_length = 0);

  // The fold, views per pass and, for Kernel::automatic on OpenCL, the
  // kernel of least predicted time for these views: the cost model of
  // docs/cost_model.md traces every 8th tile of each choice on this device
  // (tens of ms). folds: those to weigh (empty: all four); aligns: views per
  // pass to weigh, for views that can be traced together (empty: 1 and as
  // many as a pass holds). The kernel chosen traces from now on; the fold
  // and align are the caller's to pass to render or render_views. InputError
  // for no cameras or an align out of range.
  AutoChoice choose_fastest(const std::vector<Camera>& cameras, const std::vector<Fold>& folds = {},
                            const std::vector<int>& aligns = {});

  // The passes render_views traces these views in with this fold and align
  // (its rules, above): each pass the indices of its views, in the order the
  // views come. InputError for an align out of range.
  std::vector<std::vector<size_t>> passes(const std::vector<Camera>& cameras, Fold fold = Fold::none,
                                          int align = 0) const;

  BuildStats build_stats() const;
  // The device buffers now held, by name, in bytes; empty for the CPU backend.
  std::vector<std::pair<std::string, size_t>> device_buffers() const;

  std::string device_name() const;  // "cpu reference" for the CPU backend
  std::string kernel() const;       // "tile", "single" or "cpu reference"
  unsigned tile_lanes() const;      // rays per vector of the tile kernel, 8 or 16 (8 for dense meshes); 0 for the CPU backend

 private:
  // The flow planes `asked` names, for g's hits, against the scene as it is posed now.
  void add_flow(GBuffer& g, const FlowTo& to, unsigned asked);
  // The flow planes of a view no view follows: NaN flow, flow_visible 0 where it hits.
  void add_no_flow(GBuffer& g, unsigned asked);

  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Loads the OpenCL drivers on a thread of its own while the caller does
// other work (reads a scene: on PoCL about 35 ms that the read hides); a
// Renderer's device opening waits for it, and so does the destructor. It is
// this process's first use of OpenCL: a process that forks afterwards must
// not make one. Errors are left to the opening, which reports them.
class OpenClPreload {
 public:
  OpenClPreload();
  ~OpenClPreload();
  OpenClPreload(const OpenClPreload&) = delete;
  OpenClPreload& operator=(const OpenClPreload&) = delete;

 private:
  std::unique_ptr<core::OpenClPreload> impl_;
};

// The OpenCL devices this machine offers, one line each ("  <platform>:
// <name> (CPU, N compute units, <version>)"): what RendererOptions::device
// picks among (the first whose platform or name contains it). Empty when
// there is none.
std::string opencl_devices();

}  // namespace rayfold
