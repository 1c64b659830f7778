#include "pipeline/pipeline.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>

#include <unistd.h>

#include "util/errors.h"
#include "util/timer.h"

#include "bvh/bvh_build.h"
#include "fold/ray_list.h"
#include "rays/ray_order.h"
#include "rays/ray_queries.h"
#include "reference/cpu_tracer.h"
#include "util/parallel.h"

namespace rayfold::core {

Pipeline::Pipeline(const Scene& scene, const PipelineOptions& options)
    : Pipeline(scene, options, open_device(scene, options, std::launch::async)) {}

// The device opens while prepare_scene runs. Should the build throw, the
// future's destructor waits for the device first, and the build's error is
// the one reported.
Pipeline::Pipeline(const Scene& scene, const PipelineOptions& options, std::future<OpenedDevice> device)
    : Pipeline(scene, options,
               std::make_shared<const SceneData>(prepare_scene(scene, options.threads, options.braid, options.merge)),
               std::move(device)) {}

Pipeline::Pipeline(const Scene& scene, const PipelineOptions& options, std::shared_ptr<const SceneData> prebuilt)
    : Pipeline(scene, options, std::move(prebuilt), open_device(scene, options, std::launch::deferred)) {}

namespace {

// Whether an instance renders a mesh of at least BuildOptions::
// dense_triangles: one whose tree the builder makes as dense (a merged
// tree counts its largest member), whatever the merging.
bool renders_dense_mesh(const Scene& scene) {
  const size_t dense = BuildOptions{}.dense_triangles;
  for (const Instance& i : scene.instances)
    if (i.mesh < scene.meshes.size() && scene.meshes[i.mesh].triangle_count() >= dense) return true;
  return false;
}

}  // namespace

std::future<Pipeline::OpenedDevice> Pipeline::open_device(const Scene& scene, const PipelineOptions& options,
                                                          std::launch when) {
  if (options.backend != Backend::opencl) {
    std::promise<OpenedDevice> none;
    none.set_value({});
    return none.get_future();
  }
  KernelTuning tuning = options.tuning;
  tuning.dense_scene = renders_dense_mesh(scene);
  tuning.alpha_masks = has_alpha_masks(scene.meshes);
  return std::async(when, [hint = options.device_hint, precision = options.precision, tuning] {
    OpenedDevice d;
    d.device = std::make_unique<ClDevice>(hint);
    d.tracer = std::make_unique<ClTracer>(*d.device, precision, false, tuning);
    return d;
  });
}

Pipeline::Pipeline(const Scene& scene, const PipelineOptions& options, std::shared_ptr<const SceneData> prebuilt,
                   std::future<OpenedDevice> device)
    : scene_(scene), options_(options), data_(std::move(prebuilt)) {
  kernel_reason_ = "the CPU backend";
  if (options_.backend == Backend::opencl) {
    OpenedDevice opened = device.get();
    device_ = std::move(opened.device);
    tracer_ = std::move(opened.tracer);
    // PoCL runs one work-item per thread, so only the tile kernel uses the
    // CPU's vector units; on other devices the faster one is measured.
    const bool cpu = device_->info().is_cpu;
    switch (options_.kernel) {
      case Kernel::tile:
        kernel_ = KernelKind::tile;
        kernel_reason_ = "chosen";
        break;
      case Kernel::single:
        kernel_ = KernelKind::single;
        kernel_reason_ = "chosen";
        break;
      case Kernel::automatic:
      case Kernel::measure:
        kernel_ = KernelKind::tile;
        measure_kernel_ = options_.kernel == Kernel::measure || !cpu;
        kernel_reason_ = measure_kernel_ ? "to be measured" : "CPU device";
        break;
    }
    packs_planes_ = !cpu;
    if (const char* env = std::getenv("RAYFOLD_READBACK")) {
      const std::string v = env;
      if (v == "packed" || v == "hits")
        packs_planes_ = v == "packed";
      else if (v != "auto" && !v.empty())
        throw InputError("", "RAYFOLD_READBACK is '" + v + "'; it takes auto, packed or hits");
    }
  }
}

Pipeline::~Pipeline() = default;

std::string Pipeline::device_name() const {
  if (device_)
    return device_->info().name + " (" + device_->info().platform + ", " +
           std::to_string(device_->info().compute_units) + " compute units)";
  const unsigned threads = resolve_threads(options_.threads);
  return "CPU reference (" + std::to_string(threads) + " threads)";
}

unsigned Pipeline::tile_lanes() const { return tracer_ ? tracer_->tile_lanes() : 0u; }

std::string Pipeline::kernel_label() const { return tracer_ ? kernel_name(kernel_) : "cpu reference"; }

std::vector<BufferInfo> Pipeline::device_buffers() const {
  std::vector<BufferInfo> out = tracer_ ? tracer_->buffers() : std::vector<BufferInfo>{};
  if (queries_)
    for (const BufferInfo& b : queries_->buffers()) out.push_back(b);
  return out;
}

void Pipeline::ensure_capacity(size_t pixels, int groups) {
  if (!tracer_ || (pixels <= pixel_capacity_ && groups <= group_capacity_)) return;
  pixels = std::max(pixels, pixel_capacity_);
  groups = std::max({groups, group_capacity_, RF_MIRRORS});
  tracer_->upload_scene(*data_, max_tlas_nodes(*data_, groups), max_tlas_items(*data_, groups), pixels, pixels);
  pixel_capacity_ = pixels;
  group_capacity_ = groups;
  for (CachedRays& r : rays_) r.uploaded = false;  // the new buffers hold no rays yet
}

const RayList& Pipeline::ray_list(const rf_camera& params, Fold fold) {
  static_assert(static_cast<int>(Fold::xy) < 4 && ClTracer::kRaySlots >= 4, "one slot per fold mode");
  CachedRays& r = rays_[static_cast<int>(fold)];
  // The list is pixel coordinates and fold roles: it depends on the image
  // size and the principal point's integer coordinates, not on the field of
  // view (scale_x, scale_y) or the fraction of the point, so views that
  // differ only in those (random views, zooms) share it.
  const rf_camera& c = r.camera;
  const bool same = c.width == params.width && c.height == params.height && c.kx0 == params.kx0 &&
                    c.ky0 == params.ky0 && c.xpair == params.xpair && c.ypair == params.ypair;
  if (!r.built || !same) {
    r.list = make_ray_list(params, fold);
    r.camera = params;
    r.built = true;
    r.uploaded = false;
  }
  return r.list;
}

// Image-sized host buffers are checked against physical memory first, so a
// huge size fails with a message instead of an allocation failure or, with
// overcommit, the OOM killer mid-trace.
void check_host_memory(size_t pixels) {
  const double need = static_cast<double>(pixels) * (sizeof(rf_pixel_hit) + sizeof(uint32_t));
  const double have = static_cast<double>(sysconf(_SC_PHYS_PAGES)) * static_cast<double>(sysconf(_SC_PAGE_SIZE));
  if (have > 0 && need > 0.75 * have) {
    throw RuntimeFailure("the image needs " + std::to_string(static_cast<long long>(need / 1048576)) +
                         " MiB of host memory for its hits and rays; this machine has " +
                         std::to_string(static_cast<long long>(have / 1048576)) + " MiB");
  }
}

RenderResult Pipeline::render(const Camera& camera, int frames, const FrameOptions& frame_options) {
  RenderResult result;
  render_into(result, camera, frames, frame_options);
  return result;
}

void Pipeline::render_into(RenderResult& result, const Camera& camera, int frames, const FrameOptions& frame_options) {
  render_views_into(result, std::vector<Camera>{camera}, frames, frame_options);
}

void Pipeline::render_views_into(RenderResult& result, const std::vector<Camera>& cameras, int frames,
                                 const FrameOptions& frame_options) {
  begin_views(result, cameras, frame_options);
  frames = std::max(frames, 1);
  for (int f = 0; f < frames; ++f) result.frames.push_back(trace_frame(result, cameras, frame_options, f, false));
  end_views(result, cameras);
}

void Pipeline::submit_views_into(RenderResult& result, const std::vector<Camera>& cameras,
                                 const FrameOptions& frame_options) {
  begin_views(result, cameras, frame_options);
  result.frames.push_back(trace_frame(result, cameras, frame_options, 0, true));
  end_views(result, cameras);
}

void Pipeline::finish_views(RenderResult& result) {
  if (result.readback.slot < 0) return;  // rendered whole by submit
  collect_planes(result, result.frames.back());
  result.median = median_times(result.frames);
}

void Pipeline::collect_planes(RenderResult& result, FrameTimes& times) {
  const int slot = result.readback.slot;
  result.readback.slot = -1;  // also when the wait fails: the slot is free again
  const ClTracer::PackedPlanes p = tracer_->wait_packed(slot);
  result.readback.words = p.words;
  result.readback.words_per_view = p.words_per_view;
  result.readback.view_hits.assign(p.hit_counts, p.hit_counts + result.views.size());
  times.readback_ms += p.wait_ms;
  if (result.readback.pipelined) times.trace_ms = p.trace_ms;
}

void Pipeline::begin_views(RenderResult& result, const std::vector<Camera>& cameras,
                           const FrameOptions& frame_options) {
  RF_CHECK(!cameras.empty(), "nothing to render");
  RF_CHECK_LT(result.readback.slot, 0, "a result still in flight (submit_views_into without finish_views)");
  if (tracer_ && frame_options.exact_depth && options_.precision == KernelPrecision::fast)
    throw InputError("", "the exact depth runs on the exact build only; this renderer was made with the fast one, "
                         "whose reordered arithmetic drops the double-float steps");
  const Camera& camera = cameras[0];
  const size_t view_pixels = static_cast<size_t>(camera.width) * camera.height;
  const size_t pixels = view_pixels * cameras.size();
  result.fold = restrict_fold(frame_options.fold, can_fold_columns(camera), can_fold_rows(camera));
  const int groups = pass_groups(static_cast<int>(cameras.size()), result.fold);
  RF_CHECK_LE(groups, RF_GROUP_LIMIT, "more views than one pass holds");
  check_host_memory(pixels);
  ensure_capacity(pixels, groups);
  if (tracer_) tracer_->prepare_groups(groups);  // a kernel build is not trace time
  result.readback.words = nullptr;
  result.readback.words_per_view = 0;
  result.readback.channels = 0;
  result.readback.view_hits.clear();
  result.readback.pipelined = false;
  result.readback.in_place = tracer_ && frame_options.planes && frame_options.planes_in_place && cameras.size() == 1 &&
                           !packs_planes_ && tracer_->writes_host_memory();
  if (result.readback.in_place) {
    result.hits.clear();
  } else if (tracer_ && frame_options.planes && packs_planes_) {
    result.hits.clear();
    result.readback.channels = frame_options.channels;
  } else if (result.hits.size() != pixels) {
    // Not zeroed: every kernel and the CPU reference write each pixel's
    // hit, a miss included, every frame (as they do into a reused buffer).
    // Zeroing it on one thread took 9 ms of Sponza's 18 ms first frame.
    // Emptied first, so that growing copies no stale hits across.
    result.hits.clear();
    result.hits.resize(pixels);
  }
  result.frames.clear();
}

FrameTimes Pipeline::trace_frame(RenderResult& result, const std::vector<Camera>& cameras,
                                 const FrameOptions& frame_options, int f, bool pipelined) {
  const Camera& camera = cameras[0];
  const size_t view_pixels = static_cast<size_t>(camera.width) * camera.height;
  const size_t pixels = view_pixels * cameras.size();
  const bool packed = result.readback.channels != 0;
  FrameTimes times;
  FrameOptions options = frame_options;
  options.fold = result.fold;
  if (options.animate_frame >= 0) options.animate_frame += f;
  auto t0 = Clock::now();
  const RayList& rays = ray_list(camera.params, options.fold);
  times.ray_list_ms = ms_since(t0);
  result.rays = rays.entries.size();
  const Frame frame = build_frame(scene_, *data_, cameras, rays, options);
  times.cull_ms = frame.stats.cull_ms;
  times.tlas_ms = frame.stats.tlas_ms;
  result.frame_stats = frame.stats;
  result.tlas_nodes = frame.tlas_nodes.size();
  result.instances = frame.instances.size();
  result.views = frame.views;
  if (!tracer_) {
    t0 = Clock::now();
    const TraceInputs in = host_inputs(frame);
    times.upload_ms = ms_since(t0);
    t0 = Clock::now();
    const std::vector<float> depth_scales = frame.depth_scales();
    trace_cpu(in, rays, frame_camera(camera, frame), depth_scales.data(), result.hits.data(), options_.threads);
    times.trace_ms = ms_since(t0);
    return times;
  }
  CachedRays& cached = rays_[static_cast<int>(options.fold)];
  if (!cached.uploaded) {
    times.ray_list_ms += tracer_->upload_rays(rays, static_cast<int>(options.fold));
    cached.uploaded = true;
  } else {
    tracer_->use_rays(static_cast<int>(options.fold));
  }
  times.upload_ms = tracer_->upload_frame(frame);
  // A packed pass traces into the device's own buffer (unbinding any
  // host memory an earlier pass bound).
  if (result.readback.in_place)
    tracer_->bind_planes(frame_options.planes_in_place, pixels);
  else
    tracer_->bind_output(packed ? nullptr : result.hits.data(), packed ? 0 : pixels);
  const rf_camera cam = frame_camera(camera, frame);
  if (is_orthographic(camera)) {
    // The tile kernel's box tests share one origin (the eye) across a
    // tile; parallel rays go through the single-ray kernel.
    if (pipelined && packed)
      tracer_->enqueue_trace(cam, KernelKind::single);
    else
      times.trace_ms = tracer_->trace(cam, KernelKind::single);
  } else if (measure_kernel_) {
    // Both kernels write the same bits; the faster one stays. Each is
    // timed on its second trace: a driver's first launch of a kernel
    // compiles it for the work-group size (PoCL: up to a second), which
    // on a fresh kernel cache made the larger tile kernel lose.
    const double first_ms = tracer_->trace(cam, KernelKind::single) + tracer_->trace(cam, KernelKind::tile);
    const double single_ms = tracer_->trace(cam, KernelKind::single);
    const double tile_ms = tracer_->trace(cam, KernelKind::tile);
    kernel_ = tile_ms <= single_ms ? KernelKind::tile : KernelKind::single;
    char why[128];
    std::snprintf(why, sizeof why, "measured on the first frame: tile %.2f ms, single %.2f ms (second traces)",
                  tile_ms, single_ms);
    kernel_reason_ = why;
    measure_kernel_ = false;
    times.trace_ms = first_ms + single_ms + tile_ms;
    pipelined = false;  // timed by the host already
  } else if (pipelined && packed) {
    tracer_->enqueue_trace(cam, kernel_);
  } else {
    times.trace_ms = tracer_->trace(cam, kernel_);
  }
  if (result.readback.in_place) {
    times.readback_ms = tracer_->read_planes();
    return times;
  }
  if (!packed) {
    times.readback_ms = tracer_->read_hits(result.hits.data(), pixels);
    return times;
  }
  t0 = Clock::now();
  result.readback.slot = next_pack_slot_;
  next_pack_slot_ = (next_pack_slot_ + 1) % ClTracer::kPackSlots;
  tracer_->enqueue_packed_read(view_pixels, static_cast<unsigned>(cameras.size()), result.readback.channels,
                               result.readback.slot);
  times.readback_ms = ms_since(t0);
  result.readback.pipelined = pipelined;
  if (!pipelined) collect_planes(result, times);
  return times;
}

void Pipeline::end_views(RenderResult& result, const std::vector<Camera>& cameras) {
  const Camera& camera = cameras[0];
  result.kernel = kernel_label();
  result.kernel_reason = kernel_reason_;
  if (tracer_ && is_orthographic(camera)) {
    result.kernel = kernel_name(KernelKind::single);
    result.kernel_reason = "orthographic: parallel rays share no origin for the tile kernel";
  }
  result.view_warnings.assign(cameras.size(), {});
  result.warnings.clear();
  for (size_t v = 0; v < cameras.size(); ++v) {
    std::vector<std::string>& w = result.view_warnings[v];
    add_range_warnings(result.views[v].out_of_range, "rendered: at this view", w);
    if (result.views[v].trace_exponent < -125)
      w.push_back(
          "the view's distances are below 2^-125 world units: depths are subnormal floats with fewer bits, "
          "or 0 (ids, barycentrics and normals are unaffected)");
    if (pixel_angle(cameras[v]) < kFinestPixelAngle) {
      char what[200];
      std::snprintf(what, sizeof what,
                    "pixels %.2g radians apart are finer than float positions resolve (about 2^-24 of the distance): "
                    "hits may be misplaced or lost",
                    pixel_angle(cameras[v]));
      w.push_back(what);
    }
    for (const std::string& text : w)
      result.warnings.push_back(cameras.size() == 1 ? text : "view " + std::to_string(v) + ": " + text);
  }
  result.median = median_times(result.frames);
}

void Pipeline::add_range_warnings(size_t out_of_range, const char* where, std::vector<std::string>& w) const {
  if (out_of_range != 0)
    w.push_back(std::to_string(out_of_range) + " instances not " + where +
                " their size and the scene's extent are more than the float range apart");
  if (data_->blas.unresolvable_triangles != 0)
    w.push_back(std::to_string(data_->blas.unresolvable_triangles) +
                " triangles are smaller than 2^-60 of their mesh's extent, below what the triangle test resolves: "
                "they may be missed");
}

// Below this many rays a tile on average, the query tile kernel's fixed
// costs per tile (its 256 lanes are set up and written whatever the count)
// outweigh its lanes.
constexpr size_t kMinQueryTileRays = 128;

std::vector<std::string> Pipeline::intersect(const float* origins, const float* directions, size_t n, float tmin,
                                             float tmax, bool any_hit, const FrameOptions& frame_options,
                                             rf_pixel_hit* out, size_t row_length) {
  // The fast build (-cl-fast-relaxed-math) assumes finite math, which the
  // query traversal's bounds and axis-aligned rays break (it missed every
  // hit, or crashed, where the exact build answers).
  if (tracer_ && options_.precision == KernelPrecision::fast)
    throw InputError("", "ray queries run on the exact build only; this renderer was made with the fast one");
  bool one_origin = false;
  const float origin_bound = check_query_rays(origins, directions, n, tmin, tmax, &one_origin);
  if (n == 0) return {};
  // Two frames can serve a query: the re-braided one, for the tile kernel
  // and the CPU reference, and one of whole trees for the single-ray kernel
  // (FrameOptions::whole_trees), its 8-wide trees made at the renderer's
  // first query (most renderers never answer one). Each is built where a
  // chunk first needs it.
  std::optional<Frame> frames[2];
  int uploaded = -1;
  if (tracer_) {
    ensure_capacity(1, RF_MIRRORS);
    if (!queries_) queries_ = std::make_unique<ClQueryTracer>(*tracer_);
  }
  auto frame_for = [&](bool single_ray) -> const Frame& {
    const int k = single_ray ? 1 : 0;
    if (!frames[k]) {
      if (single_ray && !query_trees_built_) {
        query_trees_ = build_query_trees(*data_);
        query_trees_built_ = true;
      }
      // Again after a scene upload for more pixels or groups.
      if (single_ray && !queries_->has_query_trees()) queries_->upload_query_trees(query_trees_);
      frames[k] = build_query_frame(scene_, *data_, origin_bound, frame_options, single_ray ? &query_trees_ : nullptr);
    }
    if (tracer_ && uploaded != k) {
      queries_->upload_frame(*frames[k]);
      uploaded = k;
    }
    return *frames[k];
  };
  TraceInputs in;
  if (!tracer_) in = host_inputs(frame_for(false));
  const size_t chunk_rays = query_chunk_rays(row_length);
  std::vector<rf_query_ray>& chunk = query_rays_;  // kept: fresh pages per query cost as much as the copy
  for (size_t begin = 0; begin < n; begin += chunk_rays) {
    const size_t end = std::min(n, begin + chunk_rays);
    // Rays that share an origin (a camera's, a sensor's, a light's) go in
    // tiles through the tile kernel where it is the one that traces: the
    // same bits, traced in vector lanes.
    QueryTiles& tiles = query_plan_;
    tiles.tiles.clear();
    tiles.scattered.clear();
    // (One origin for all is one for each chunk; a chunk's may be one
    // where all are not.)
    if (tracer_ && kernel_ == KernelKind::tile)
      plan_query_tiles(origins + 3 * begin, end - begin, row_length, kMinQueryTileRays, tiles,
                       one_origin ? std::optional<bool>(true) : std::nullopt);
    // The others one by one, neighbours in space and direction one after
    // the other.
    if (tiles.tiles.empty())
      scattered_ray_order(origins + 3 * begin, directions + 3 * begin, end - begin, tiles.scattered,
                          options_.threads);
    const Frame& frame = frame_for(tracer_ && tiles.tiles.empty());
    const unsigned flags = frame.normals ? 0u : RF_WRITE_NO_NORMALS;
    ClQueryTracer::QueryRays rays;
    rays.count = end - begin;
    if (!tiles.tiles.empty()) {  // the tile kernel reads the arrays themselves
      rays.origins = origins + 3 * begin;
      rays.directions = directions + 3 * begin;
      rays.tmin = tmin;
      rays.tmax = tmax;
      rays.exponent = -frame.views.at(0).trace_exponent;
    } else {
      to_trace_space(origins, directions, begin, end, tmin, tmax, frame, chunk, tiles.scattered);
      rays.records = &chunk;
    }
    if (tracer_)
      queries_->trace_queries(rays, any_hit, flags, out + begin, &tiles);
    else
      trace_queries_cpu(in, chunk, any_hit, flags, out + begin, options_.threads, tiles.scattered);
  }
  // Both frames hold the same instances in the same trace space.
  std::vector<std::string> warnings;
  add_range_warnings((frames[0] ? *frames[0] : *frames[1]).views[0].out_of_range, "traced: in world space", warnings);
  return warnings;
}

TraceInputs Pipeline::host_inputs(const Frame& frame) {
  // The bottom level's nodes are copied on the first host trace: an OpenCL
  // renderer that never traces on the host never holds them twice.
  if (nodes_.size() < data_->blas.nodes.size()) nodes_.assign(data_->blas.nodes.begin(), data_->blas.nodes.end());
  nodes_.resize(frame.node_base);
  nodes_.insert(nodes_.end(), frame.tlas_nodes.begin(), frame.tlas_nodes.end());
  TraceInputs in;
  in.nodes = nodes_.data();
  in.node_count = nodes_.size();
  in.tris = data_->blas.tris.data();
  in.tri_count = data_->blas.tris.size();
  in.instances = frame.instances.data();
  in.instance_count = frame.instances.size();
  const std::vector<rf_normal_xform>& normals = frame.normal_xforms.empty() ? data_->normal_xforms : frame.normal_xforms;
  in.normal_xforms = normals.data();
  in.normal_xform_count = normals.size();
  in.tlas_root = frame.tlas_root;
  in.depth_xforms = frame.depth_xforms.empty() ? nullptr : frame.depth_xforms.data();
  in.depth_instances = frame.depth_instances;
  in.alpha = data_->alpha.view();
  return in;
}

RenderResult view_result(const RenderResult& pass, size_t v) {
  RF_CHECK(v < pass.views.size() && pass.hits.size() % pass.views.size() == 0, "no such view in the pass");
  RF_CHECK_LT(pass.readback.slot, 0, "view of a pass still in flight");
  RenderResult out;
  if (pass.readback.channels != 0) {
    out.readback.words = pass.readback.words + v * pass.readback.words_per_view;
    out.readback.words_per_view = pass.readback.words_per_view;
    out.readback.channels = pass.readback.channels;
    out.readback.view_hits = {pass.readback.view_hits.at(v)};
  } else {
    const size_t n = pass.hits.size() / pass.views.size();
    out.hits.assign(pass.hits.begin() + v * n, pass.hits.begin() + (v + 1) * n);
  }
  out.median = pass.median;
  out.frames = pass.frames;
  out.frame_stats = pass.frame_stats;
  out.rays = pass.rays;
  out.tlas_nodes = pass.tlas_nodes;
  out.instances = pass.instances;
  out.views = {pass.views[v]};
  out.fold = pass.fold;
  out.view_warnings = {pass.view_warnings.at(v)};
  out.warnings = pass.view_warnings.at(v);
  return out;
}

FrameTimes median_times(const std::vector<FrameTimes>& frames) {
  auto pick = [&](double FrameTimes::*field) {
    std::vector<double> v;
    for (const FrameTimes& t : frames) v.push_back(t.*field);
    return median(v);
  };
  FrameTimes m;
  m.cull_ms = pick(&FrameTimes::cull_ms);
  m.tlas_ms = pick(&FrameTimes::tlas_ms);
  m.upload_ms = pick(&FrameTimes::upload_ms);
  m.ray_list_ms = pick(&FrameTimes::ray_list_ms);
  m.trace_ms = pick(&FrameTimes::trace_ms);
  m.readback_ms = pick(&FrameTimes::readback_ms);
  return m;
}

double Pipeline::program_build_ms() const { return tracer_ ? tracer_->program_build_ms() : 0.0; }

}  // namespace rayfold::core
