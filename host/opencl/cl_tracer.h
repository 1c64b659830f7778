// Device buffers and the camera trace kernels. The scene part (bottom-level
// nodes, triangles, normal matrices) is uploaded once; a frame re-uploads only
// its top-level nodes and instances, into space reserved at scene upload. Ray
// queries trace through the same scene beside it (cl_query_tracer.h).
#pragma once

#include <string>
#include <vector>

#include "fold/frame.h"
#include "fold/ray_list.h"
#include "opencl/cl_device.h"

namespace rayfold::core {

struct BufferInfo {
  std::string name;
  size_t bytes = 0;
};

// Which kernel traces the ray list (kernels/rayfold.cl).
enum class KernelKind {
  tile,    // one work-item per tile of up to 256 rays, SIMD across the rays: CPU devices
  single,  // one work-item per ray
};
const char* kernel_name(KernelKind k);

// How the kernels are built beyond precision: for measuring one build
// against another in one process (rayfold-peers), never for correctness.
struct KernelTuning {
  unsigned tile_lanes = 0;  // rays per tile-kernel vector, 8 or 16; 0: the device's (tile_lanes)
  std::string defines;      // more build options, such as "-DRF_KEEP_EACH_GROUP=8"
  // The scene renders a mesh the builder treats as dense (BuildOptions::
  // dense_triangles): its tile vectors default to 8 lanes (tile_lanes).
  bool dense_scene = false;
  // The scene has alpha-masked triangles (Mesh::alpha): the programs are
  // built with RF_ALPHA and take its tables (upload_scene sets it from the
  // scene; set ahead, the first program is built for it).
  bool alpha_masks = false;
};

// Rays per vector in the tile kernel: `requested` when it is 8 or 16, else
// RAYFOLD_TILE_LANES when set, else 8 for a dense scene, else the device's
// native float vector width, 8 (AVX2) or 16 (AVX-512). Dense meshes hold
// about a triangle a pixel, and a leaf meets few rays of a 4x4 block: on
// an AVX-512 Xeon, random views of the dragon traced 1.07x faster with 8
// lanes (4x2 blocks), the armadillo 1.03x to 1.04x, where 16 lanes are as
// fast or faster on every other scene (docs/results.md).
unsigned tile_lanes(const DeviceInfo& info, unsigned requested = 0, bool dense_scene = false);

struct TraceTimes {
  double upload_ms = 0.0;
  double trace_ms = 0.0;
  double readback_ms = 0.0;
};

class ClTracer {
 public:
  // tile_stats: build the tile kernel with its traversal counters
  // (kernels/rf_tile.h), a diagnostic for rayfold-stats; slower.
  ClTracer(ClDevice& device, KernelPrecision precision = KernelPrecision::exact, bool tile_stats = false,
           KernelTuning tuning = {});
  ~ClTracer();
  ClTracer(const ClTracer&) = delete;
  ClTracer& operator=(const ClTracer&) = delete;

  // Rays per vector of the tile kernel this tracer builds.
  unsigned tile_lanes() const {
    return rayfold::core::tile_lanes(device_.info(), tuning_.tile_lanes, tuning_.dense_scene);
  }

  // Allocates every buffer for this scene and image size, checking the
  // device's memory first (RuntimeFailure when it would not fit).
  // pixel_count: the hits of every view of the largest pass. A CPU device
  // reads data's triangles and wide nodes in place: `data` must stay as it
  // is until the next upload_scene or the tracer's end.
  void upload_scene(const SceneData& data, size_t max_tlas_nodes, size_t max_instances, size_t max_rays,
                    size_t pixel_count);
  // The frame's top level, normal matrices and per-view depth scales; returns
  // the upload time in ms.
  double upload_frame(const Frame& frame);
  // Uploads a ray list into one of kRaySlots slots and makes it the one
  // traced; a renderer keeps one slot per fold mode, so that alternating
  // modes (a comparison, a benchmark) does not upload again, and one for the
  // predictor's samples.
  static constexpr int kRaySlots = 5;
  double upload_rays(const RayList& rays, int slot = 0);
  // Traces the list already in `slot` from now on.
  void use_rays(int slot);
  // Traces the uploaded rays with the given kernel; ms of kernel time,
  // measured around a finish(). A pass of more than 4 (view, mirror) groups
  // runs a program built for that many (compiled on first use; prepare_groups
  // does it ahead, outside any timing).
  double trace(const rf_camera& camera, KernelKind kernel);
  // The same without waiting: the kernel is queued and this returns at
  // once; a packed read queued after it reports its device time.
  void enqueue_trace(const rf_camera& camera, KernelKind kernel);
  void prepare_groups(int groups);

  // Packed readback (kernels/rayfold.cl, rf_pack_planes): the planes
  // `channels` (RF_PLANE_*) names of the last trace's hits, `views` views of
  // view_pixels pixels each, packed on the device and read, without
  // waiting, into pinned host memory slot `slot`. There are kPackSlots, so
  // one pass's planes can be read on the host while the next one traces.
  static constexpr int kPackSlots = 2;
  void enqueue_packed_read(size_t view_pixels, unsigned views, unsigned channels, int slot);
  struct PackedPlanes {
    const uint32_t* words = nullptr;       // view after view, words_per_view each (rf_types.h, RF_PLANE_*)
    const uint32_t* hit_counts = nullptr;  // per view: pixels that hit
    size_t words_per_view = 0;
    double wait_ms = 0.0;   // how long the host waited for the read
    double trace_ms = 0.0;  // device time of the trace queued before the read
  };
  // Waits for slot's read. The words stay valid until that slot is read into again.
  PackedPlanes wait_packed(int slot);
  // What the query tracer (cl_query_tracer.h) traces through: the scene's
  // buffers and the top-level root of the frame uploaded last. The counters
  // say whether the scene or the frame changed since.
  struct SceneBuffers {
    cl::Buffer nodes, wide_nodes, tris, instances, normal_xforms;
    uint32_t tlas_root = RF_INVALID;
  };
  SceneBuffers scene_buffers() const;
  // A masked scene's tables (rf_alpha.h) as the last arguments of `kernel`
  // from argument a on; returns the next argument. Nothing without masks:
  // its kernels are built without them.
  int set_alpha_args(cl::Kernel& kernel, int a) const;
  uint64_t scene_uploads() const { return scene_uploads_; }
  uint64_t frame_uploads() const { return frame_uploads_; }
  // The program built for up to `groups` transform groups (built here on
  // first use), whose query kernels the query tracer takes.
  const cl::Program& program(int groups) { return programs_for(groups).program; }
  ClDevice& device() { return device_; }
  // Milliseconds spent building programs so far: about 2 s on a machine's
  // first use of this rayfold version with PoCL, about 0.1 s once PoCL's
  // cache ($XDG_CACHE_HOME/pocl or ~/.cache/pocl) holds them.
  double program_build_ms() const { return build_ms_; }
  // Where the next trace writes its hits. On CPU devices the kernel writes
  // straight into `out` (a buffer over host memory), and read_hits only
  // synchronises; elsewhere read_hits copies the device buffer into `out`.
  void bind_output(rf_pixel_hit* out, size_t pixel_count);
  double read_hits(rf_pixel_hit* out, size_t pixel_count);
  // Whether the device writes host memory in place (a CPU device), which
  // bind_planes needs.
  bool writes_host_memory() const;
  // Where the next camera trace writes its answers instead: one view's
  // planes of pixel_count pixels in host memory (writes_host_memory only);
  // read_planes synchronises them and unbinds them.
  void bind_planes(const AnswerPlanes* planes, size_t pixel_count);
  double read_planes();

  // The tile kernel's counters of the last trace, RF_TILE_STAT_COUNT per
  // tile (a tracer built with tile_stats only).
  std::vector<uint32_t> read_tile_stats();

  std::vector<BufferInfo> buffers() const;
  size_t device_bytes() const;

 private:
  // The kernels built for up to `groups` transform groups (RF_MAX_GROUPS):
  // 4, the one view of a plain render, then 8, 16 and 32 for aligned views.
  // The hit records they keep per ray grow with it.
  struct Programs {
    int groups = 0;
    cl::Program program;
    cl::Kernel single, tile, pack;
  };
  Programs& programs_for(int groups);

  ClDevice& device_;
  KernelPrecision precision_;
  std::vector<Programs> programs_;
  cl::Buffer nodes_, wide_nodes_, tris_, instances_, normal_xforms_, hits_, depth_scales_;
  // The frame's exact-depth table (Frame::depth_xforms): one entry until a
  // frame asks for the exact depth, then grown to what a pass needs.
  cl::Buffer depth_xforms_;
  cl::Buffer alpha_bufs_[4];  // index, records, images, texels (bvh/alpha_tables.h), with tuning_.alpha_masks
  size_t depth_xforms_capacity_ = 0;
  uint32_t depth_instances_ = 0;
  // One uploaded ray list and its tile table. Slot 0's rays buffer is made
  // with the scene (its size is checked against the device's memory); the
  // others grow on first use.
  struct RaySlot {
    cl::Buffer rays, tiles;
    size_t rays_capacity = 0, tiles_capacity = 0;
    uint32_t ray_count = 0, tile_count = 0;
  };
  RaySlot slots_[kRaySlots];
  int slot_ = 0;
  bool tile_stats_ = false;
  KernelTuning tuning_;
  cl::Buffer stats_;
  // Packed readback, per slot: the device's packed planes and per-view hit
  // counts, and the pinned host memory (CL_MEM_ALLOC_HOST_PTR, mapped once)
  // they are read into; grown as passes need. The reads go through their
  // own queue, so a GPU copies one pass back while it traces the next.
  struct PinnedSlot {
    cl::Buffer packed, counts;
    cl::Buffer pinned;
    uint32_t* host = nullptr;  // pinned's mapping: words, then one hit count per view
    size_t capacity = 0;       // words of packed and host
    size_t words_per_view = 0, views = 0;
    cl::Event done, trace;
    bool pending = false;
  };
  PinnedSlot pinned_[kPackSlots];
  cl::CommandQueue read_queue_;
  cl::Event last_trace_;
  cl::Buffer host_hits_;  // over bound host memory (CPU devices)
  rf_pixel_hit* host_out_ = nullptr;
  size_t host_count_ = 0;
  // The planes bind_planes bound, in rf_answers' order (z, normal, uv,
  // instance, primitive), null buffers where not asked for; the hits are
  // not written while planes_bound_.
  static constexpr int kAnswerPlanes = 5;
  cl::Buffer plane_bufs_[kAnswerPlanes];
  void* plane_ptrs_[kAnswerPlanes] = {};
  size_t plane_bytes_[kAnswerPlanes] = {};
  bool planes_bound_ = false;
  // Sets a kernel's rf_answers arguments from index a: `hits`, or the
  // kAnswerPlanes `planes` (null buffers where not asked for); returns the
  // next index.
  int set_answer_args(cl::Kernel& kernel, int a, const cl::Buffer* hits, const cl::Buffer* planes);
  std::vector<BufferInfo> buffer_info_;
  uint32_t blas_node_count_ = 0;
  uint32_t tlas_root_ = RF_INVALID;
  uint64_t scene_uploads_ = 0, frame_uploads_ = 0;
  size_t max_tlas_nodes_ = 0, max_instances_ = 0, max_rays_ = 0, pixel_count_ = 0;
  double build_ms_ = 0.0;
};

}  // namespace rayfold::core
