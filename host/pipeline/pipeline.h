// The primary-visibility pipeline: bottom-level trees once per scene, then
// per frame culling, top-level build, upload, ray list, trace and readback,
// on the OpenCL device or on the CPU reference.
#pragma once

#include <array>
#include <future>
#include <memory>
#include <string>
#include <vector>

#include "fold/frame.h"
#include "opencl/cl_query_tracer.h"
#include "opencl/cl_tracer.h"
#include "pipeline/cost_model.h"
#include "rayfold/types.h"
#include "reference/trace_inputs.h"
#include "scene/camera.h"
#include "scene/scene.h"
#include "util/median.h"
#include "util/page_aligned.h"

namespace rayfold::core {

// The tracer and the kernel are the public rayfold::Backend and
// rayfold::Kernel (rayfold/types.h).

struct PipelineOptions {
  Backend backend = Backend::opencl;
  Kernel kernel = Kernel::automatic;
  KernelPrecision precision = KernelPrecision::exact;
  std::string device_hint;  // see ClDevice
  unsigned threads = 0;     // CPU backend and BLAS builds; 0 = all cores
  BraidOptions braid;       // how the top level opens the bottom-level trees
  MergeOptions merge;       // which instances share a bottom-level tree (bvh/blas.h)
  KernelTuning tuning;      // benchmarks' A/B of kernel builds (opencl/cl_tracer.h); default: the device's
};

// Per-frame phase times in ms (medians when several frames are rendered).
struct FrameTimes {
  double cull_ms = 0.0;
  double tlas_ms = 0.0;
  double upload_ms = 0.0;    // top-level nodes and instances
  double ray_list_ms = 0.0;  // building (and uploading) the ray list; 0 when the last one still holds
  double trace_ms = 0.0;
  double readback_ms = 0.0;
};

// A frame's hits: left as allocated (the kernels write every pixel of
// every frame), large ones in 2 MiB pages kept for reuse (util/page_aligned.h).
using HitBuffer = PageAlignedVector<rf_pixel_hit>;

// How a pass's planes came back when it asked for planes
// (FrameOptions::planes) rather than 32-byte hits (RenderResult::hits is
// then empty), and its place in the pipeline while in flight: the tracer's
// state for the pass, apart from what the pass found.
struct PlaneReadback {
  // Packed (where Pipeline::packs_planes): the planes `channels` names, view
  // after view, words_per_view words each (rf_types.h, RF_PLANE_*), in the
  // renderer's pinned memory: valid until the second pass submitted after
  // this one. view_hits: per view, the pixels that hit.
  const uint32_t* words = nullptr;
  size_t words_per_view = 0;
  unsigned channels = 0;
  std::vector<size_t> view_hits;
  // The kernel wrote the planes into FrameOptions::planes_in_place.
  bool in_place = false;
  int slot = -1;  // the tracer's readback slot while the pass is in flight
  bool pipelined = false;  // submitted by submit_views_into: trace_ms is the kernel's device time
};

struct RenderResult {
  // width * height per view, row-major, row 0 at the top; view after view.
  HitBuffer hits;
  FrameTimes median;
  std::vector<FrameTimes> frames;
  FrameStats frame_stats;        // of the last frame
  size_t rays = 0;               // rays traced per frame
  size_t tlas_nodes = 0;         // of the last frame
  size_t instances = 0;          // traced instances (copies per view and mirror included) of the last frame
  std::vector<FrameView> views;  // each view's trace space and losses, of the last frame
  // The fold traced: the one asked for, less an axis the camera's principal
  // point cannot mirror exactly (camera.h, can_fold_columns).
  Fold fold = Fold::none;
  // What this render may have lost, in words: instances beyond the float
  // range at this view, pixels finer than float positions resolve. Empty
  // when the render is within rayfold's exact range (docs/exactness.md).
  // Per view; `warnings` is view 0's for one view, else every view's with
  // "view k: " in front.
  std::vector<std::vector<std::string>> view_warnings;
  std::vector<std::string> warnings;
  // The kernel that traced this render and why (Pipeline::kernel_label and
  // kernel_reason, but an orthographic view's is the single-ray kernel's).
  std::string kernel, kernel_reason;

  // Where the planes are when a pass asked for planes, not hits.
  PlaneReadback readback;
};

class Pipeline {
 public:
  // Builds the bottom-level trees and, for OpenCL, the kernels. The scene must
  // outlive the renderer.
  Pipeline(const Scene& scene, const PipelineOptions& options);
  // With trees built before (prepare_scene of this scene with options.braid,
  // or read from a scene file), shared with whoever else holds them: builds
  // none.
  Pipeline(const Scene& scene, const PipelineOptions& options, std::shared_ptr<const SceneData> prebuilt);
  ~Pipeline();

  RenderResult render(const Camera& camera, int frames = 1, const FrameOptions& frame_options = {});
  // The same into `result`, reusing its hit buffer when it already has the
  // image's size (every pixel is overwritten): no allocation per frame.
  void render_into(RenderResult& result, const Camera& camera, int frames = 1, const FrameOptions& frame_options = {});
  // Views that share their rays (can_align), traced together: one ray list
  // and one top-level tree over every view's copies, each view's hits the
  // bits of that view rendered alone. At most max_pass_views(fold) views.
  void render_views_into(RenderResult& result, const std::vector<Camera>& cameras, int frames = 1,
                         const FrameOptions& frame_options = {});
  // render_views_into for one frame, split in two so that the host's work
  // for the next pass (culling, top level, upload, handing this one's
  // G-buffers on) overlaps this pass's trace and readback: submit queues
  // the pass and returns without waiting where it reads packed planes back
  // (FrameOptions::planes and packs_planes()), else renders it whole;
  // finish waits for it. At most ClTracer::kPackSlots passes in flight,
  // each with its own result, finished in the order submitted.
  void submit_views_into(RenderResult& result, const std::vector<Camera>& cameras, const FrameOptions& frame_options);
  void finish_views(RenderResult& result);
  // Whether passes that take planes read them packed from the device: on
  // every OpenCL device but a CPU one (there the kernel writes into host
  // memory), or as RAYFOLD_READBACK says ("packed", "hits"; "auto").
  bool packs_planes() const { return packs_planes_; }

  // Ray queries (rays/ray_queries.h): for each of n world-space rays
  // (origins, directions n x 3) its closest hit with tmin < t <= tmax, or
  // with any_hit the first one found, as a pixel's hit info (z = t along the
  // given direction). In chunks, so memory stays bounded for any n. The
  // frame options' moved and normals apply. InputError for a bad ray, or
  // on a renderer of the fast build (KernelPrecision::fast).
  // Returns what the answers may have lost, in words (as a render's).
  // row_length: the rays are an image's rows of this many (0: not known),
  // which the tile kernel traces in square blocks.
  std::vector<std::string> intersect(const float* origins, const float* directions, size_t n, float tmin, float tmax,
                                     bool any_hit, const FrameOptions& frame_options, rf_pixel_hit* out,
                                     size_t row_length = 0);

  const SceneData& scene_data() const { return *data_; }
  const std::shared_ptr<const SceneData>& shared_scene_data() const { return data_; }
  std::string device_name() const;
  // The OpenCL kernel that traces (Kernel resolved for the device;
  // before the first frame of a measured choice, the tile kernel);
  // meaningless for the CPU backend. Orthographic cameras always trace with
  // the single-ray kernel.
  KernelKind kernel() const { return kernel_; }
  // "tile" or "single" (OpenCL), "cpu reference" (CPU backend).
  std::string kernel_label() const;
  // Rays per vector of the tile kernel (8 or 16); 0 for the CPU backend.
  unsigned tile_lanes() const;
  // Why that kernel: "chosen", "CPU device", "measured on the first frame"
  // with the times, or, before that frame, "to be measured".
  const std::string& kernel_reason() const { return kernel_reason_; }
  std::vector<BufferInfo> device_buffers() const;  // empty for the CPU backend

  // Predicts each choice's time per view for these views, which must share
  // their rays (can_align), on this renderer's device, by the cost model of
  // docs/cost_model.md: every `stride`-th tile of the choice's ray list is
  // traced (full-resolution tiles keep the render's coherence), the time
  // less the launch overhead scaled to every tile; a choice that aligns
  // probes its first pass, one that does not the middle view. The CPU
  // backend predicts its one tracer (the kernel is ignored).
  std::vector<Prediction> predict(const std::vector<Camera>& views, const std::vector<Choice>& choices, int stride = 8);
  // From now on trace with this kernel (a choice made by predict); why: for
  // kernel_reason().
  void set_kernel(KernelKind kernel, const std::string& why);
  double blas_build_ms() const { return data_->blas.build_ms; }
  // The OpenCL programs' build so far (ClTracer::program_build_ms); 0 on the
  // CPU backend.
  double program_build_ms() const;

 private:
  // The OpenCL device and its kernels. They do not depend on the scene, so
  // they are opened on a thread of their own while the trees are built: on
  // PoCL that is about 70 ms of driver start-up and program loading, which
  // a large scene's build hides.
  struct OpenedDevice {
    std::unique_ptr<ClDevice> device;
    std::unique_ptr<ClTracer> tracer;
  };
  // async beside a build; deferred (on the caller's thread, when taken)
  // where there is none to overlap.
  static std::future<OpenedDevice> open_device(const Scene& scene, const PipelineOptions& options, std::launch when);
  Pipeline(const Scene& scene, const PipelineOptions& options, std::future<OpenedDevice> device);
  Pipeline(const Scene& scene, const PipelineOptions& options, std::shared_ptr<const SceneData> prebuilt,
           std::future<OpenedDevice> device);
  // The warnings of instances lost to the float range (`where` says how)
  // and of triangles below what the test resolves.
  void add_range_warnings(size_t out_of_range, const char* where, std::vector<std::string>& w) const;
  // render_views_into's phases: the pass's checks, buffers and fold; one
  // frame (pipelined: without waiting for a packed readback); the kernel
  // labels and warnings.
  void begin_views(RenderResult& result, const std::vector<Camera>& cameras, const FrameOptions& frame_options);
  FrameTimes trace_frame(RenderResult& result, const std::vector<Camera>& cameras, const FrameOptions& frame_options,
                         int frame, bool pipelined);
  void end_views(RenderResult& result, const std::vector<Camera>& cameras);
  // Waits for a pass's packed readback; its planes into result, the wait into times.
  void collect_planes(RenderResult& result, FrameTimes& times);
  // Device buffers for this many pixels (every view's) and top-level groups.
  void ensure_capacity(size_t pixels, int groups);
  // The CPU reference's inputs for a frame: its top level placed after the
  // bottom-level nodes (in nodes_), its normal matrices when it has its own.
  TraceInputs host_inputs(const Frame& frame);
  // The ray list for this image and fold: it does not depend on the
  // camera's pose or field of view, so one per fold mode (and its upload)
  // is kept while the image size and principal point stay the same.
  const RayList& ray_list(const rf_camera& params, Fold fold);

  const Scene& scene_;
  PipelineOptions options_;
  std::shared_ptr<const SceneData> data_;  // read-only once built
  std::vector<rf_node> nodes_;  // BLAS nodes, then the current frame's TLAS (host traces only)
  // The single-ray query kernel's trees (intersect), read in place by a
  // CPU device: declared before the tracer, whose buffers over them go first.
  Wide8Trees query_trees_;
  bool query_trees_built_ = false;
  std::unique_ptr<ClDevice> device_;
  std::unique_ptr<ClTracer> tracer_;
  std::unique_ptr<ClQueryTracer> queries_;  // made at the first ray query
  KernelKind kernel_ = KernelKind::single;
  bool measure_kernel_ = false;  // time both kernels on the next traced frame
  bool packs_planes_ = false;
  int next_pack_slot_ = 0;
  std::string kernel_reason_;
  size_t pixel_capacity_ = 0;
  int group_capacity_ = 0;
  struct CachedRays {
    RayList list;
    rf_camera camera{};
    bool built = false, uploaded = false;
  };
  std::array<CachedRays, 4> rays_;      // by fold mode
  std::vector<rf_query_ray> query_rays_;  // intersect's trace-space rays, one chunk
  QueryTiles query_plan_;                 // and their tiles, its image order kept from query to query
  static constexpr int kProbeSlot = 4;  // the tracer's ray slot for predict's samples
};

// View v of a pass's result: its hits, trace space and warnings; the times
// and counters stay the pass's.
RenderResult view_result(const RenderResult& pass, size_t v);

// Throws RuntimeFailure when the host buffers of an image of this many
// pixels (its hits or planes, its rays) would take more than 3/4 of the
// machine's memory: a message, not the OOM killer mid-trace.
void check_host_memory(size_t pixels);

// Each phase's median over frames.
FrameTimes median_times(const std::vector<FrameTimes>& frames);

}  // namespace rayfold::core
