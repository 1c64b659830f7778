#include "rayfold/renderer.h"

#include "api/convert.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>

#include "api/pipeline_options.h"
#include "api/resolve_gbuffer.h"
#include "api/scene_state.h"
#include "fold/view_passes.h"
#include "opencl/cl_device.h"
#include "pipeline/pipeline.h"
#include "rayfold/errors.h"
#include "rays/ray_queries.h"
#include "resolve/flow.h"
#include "util/errors.h"
#include "util/parallel.h"
#include "util/timer.h"

namespace rayfold {

struct Renderer::Impl {
  std::shared_ptr<detail::SceneState> state;
  core::PipelineOptions options;
  std::unique_ptr<core::Pipeline> core;
  uint64_t built_version = 0;  // SceneState::structure_version the trees were built for
  uint64_t built_clock = 0;    // SceneState::clock then: later set_transforms are moves
  core::RenderResult result;   // its hit buffer is reused render to render
  core::RenderResult second_result;  // the pass in flight beside it (render_views, packed readback)
  std::vector<rf_pixel_hit> query_hits;  // a query chunk's answers, kept from query to query
  std::vector<float> flow_origins, flow_directions;  // flow_visible's segments, kept from render to render
  std::vector<uint32_t> flow_pixels;                 // the pixel of each segment
  bool planar_depth = false;   // RendererOptions::depth
  bool exact_depth = false;    // RendererOptions::exact_depth
  bool cull = true;            // RendererOptions::cull
  bool planes_in_place = false;  // RAYFOLD_PLANES_IN_PLACE=1: render_into's kernel writes the planes (A/B)
  // Trees of the default braid and merging are the scene's, shared with every
  // renderer of it; others are this renderer's own.
  bool shares_trees = true;
  size_t builds = 0;  // trees this renderer built (BuildStats::builds)

  void build() {
    core.reset();
    if (!shares_trees) {
      options.merge.dynamic = state->merge().dynamic;  // kept apart, when merging at all
      core = std::make_unique<core::Pipeline>(state->scene, options);
      ++builds;
    } else if (state->trees && state->trees_version == state->structure_version) {
      core = std::make_unique<core::Pipeline>(state->scene, options, state->trees);
    } else {
      options.merge = state->merge();
      core = std::make_unique<core::Pipeline>(state->scene, options);
      ++builds;
      state->trees = core->shared_scene_data();
      state->trees_version = state->structure_version;
      state->trees_clock = state->clock;
    }
    built_clock = shares_trees ? state->trees_clock : state->clock;  // instances set_transform moved since are moves
    built_version = state->structure_version;
  }

  // Instances set_transform moved since the trees were built; rebuilds when
  // the scene's structure changed, a moved instance was hidden at build (a
  // singular transform then: it has no tree_from_world to start from) or
  // shares a merged tree (which moves only whole; rebuilt, it keeps a tree
  // of its own, SceneState::merge).
  std::vector<uint32_t> moved() {
    if (state->structure_version != built_version) build();
    std::vector<uint32_t> out;
    for (size_t i = 0; i < state->moved_at.size(); ++i)
      if (state->moved_at[i] > built_clock) out.push_back(static_cast<uint32_t>(i));
    for (uint32_t i : out)
      if (core->scene_data().blas.merged[i] ||
          (!core->scene_data().renderable[i] && !state->scene.meshes[state->scene.instances[i].mesh].indices.empty())) {
        if (shares_trees) state->trees.reset();  // they lack this instance's tree space too
        build();
        return {};
      }
    return out;
  }
};

core::PipelineOptions detail::pipeline_options(const RendererOptions& options) {
  core::PipelineOptions o;
  o.backend = options.backend;
  o.device_hint = options.device;
  o.kernel = options.kernel;
  o.threads = options.threads;
  if (options.braid < 0 || options.braid > 1024)
    throw InputError("",
                     "braid must be 0 (whole trees) to 1024 items per instance, not " + std::to_string(options.braid));
  o.braid.items_per_instance = static_cast<size_t>(options.braid);
  o.braid.enabled = options.braid > 0;
  o.merge.enabled = options.merge_static;
  if (options.fast_math && options.exact_depth)
    throw InputError("", "exact_depth runs on the exact kernels; fast_math reorders the double-float steps away");
  o.precision = options.fast_math ? core::KernelPrecision::fast : core::KernelPrecision::exact;
  return o;
}

Renderer::Renderer(const Scene& scene, const RendererOptions& options) : impl_(std::make_unique<Impl>()) {
  impl_->state = scene.state();
  impl_->options = detail::pipeline_options(options);
  impl_->planar_depth = options.depth == Depth::planar;
  impl_->exact_depth = options.exact_depth;
  impl_->cull = options.cull;
  const char* in_place = std::getenv("RAYFOLD_PLANES_IN_PLACE");
  impl_->planes_in_place = in_place && std::string(in_place) == "1";
  const RendererOptions defaults;
  impl_->shares_trees = options.braid == defaults.braid && options.merge_static == defaults.merge_static;
  impl_->build();
}

Renderer::~Renderer() = default;
Renderer::Renderer(Renderer&&) noexcept = default;
Renderer& Renderer::operator=(Renderer&&) noexcept = default;

namespace {

void check_channels(unsigned channels, unsigned allowed = kEveryChannel) {
  if ((channels & kFlowChannels) && !(allowed & kFlowChannels) && !(channels & ~kAnyChannel))
    throw InputError("",
                     "flow and flow_visible need the view the flow goes to: a single view's render with it "
                     "(Python: render's flow_to=; C++: render(camera, fold, channels, FlowTo{...})), or a "
                     "list of views, each flowing to the next (render_views, iter_views)");
  if (channels == 0u || (channels & ~allowed) != 0u)
    throw InputError("", allowed == kAllChannels
                             ? "channels must be a nonzero combination of kDepth, kNormal, kUv, kInstanceId and "
                               "kPrimitiveId, not " +
                                   std::to_string(channels)
                             : "channels must be a nonzero combination of the Channels flags (kDepth to "
                               "kMappedNormal), not " +
                                   std::to_string(channels));
}

// A G-buffer's planes and a ray query's answers have one layout: per pixel
// or ray a depth (t), a normal (3), uv (2), an instance and a primitive.
// Sizes the planes `channels` names for n of them and empties the others.
// A plane that grows is new memory, which the operating system faults in
// and zeroes page by page (29 MB for a 720p G-buffer of every channel: 28 ms
// on one core of a 2-core machine, as long as the trace), so the growing
// planes are sized side by side on `threads` threads, largest first.
void size_planes(unsigned channels, size_t n, unsigned threads, std::vector<float>& depth, std::vector<float>& normal,
                 std::vector<float>& uv, std::vector<uint32_t>& instance_id, std::vector<uint32_t>& primitive_id) {
  std::vector<std::function<void()>> grow;
  auto plane = [&](auto& v, unsigned bit, size_t per_item) {
    const size_t size = per_item * n;
    if (!(channels & bit)) {
      v.clear();
      v.shrink_to_fit();
    } else if (v.capacity() >= size) {
      v.resize(size);
    } else {
      grow.push_back([&v, size] { v.resize(size); });
    }
  };
  plane(normal, kNormal, 3);
  plane(uv, kUv, 2);
  plane(depth, kDepth, 1);
  plane(instance_id, kInstanceId, 1);
  plane(primitive_id, kPrimitiveId, 1);
  core::parallel_for(grow.size(), grow.size() > 1 ? threads : 1, 1, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) grow[i]();
  });
}

// A plane's memory, null when it is not asked for (empty).
template <class T>
T* data_or_null(std::vector<T>& v) {
  return v.empty() ? nullptr : v.data();
}

// Writes core hits into such planes, those left empty skipped.
class PlaneWriter {
 public:
  PlaneWriter(std::vector<float>& depth, std::vector<float>& normal, std::vector<float>& uv,
              std::vector<uint32_t>& instance_id, std::vector<uint32_t>& primitive_id)
      : depth_(data_or_null(depth)),
        normal_(data_or_null(normal)),
        uv_(data_or_null(uv)),
        instance_(data_or_null(instance_id)),
        primitive_(data_or_null(primitive_id)) {}
  // Hit h into element i.
  void put(size_t i, const rf_pixel_hit& h) const {
    if (depth_) depth_[i] = h.z;
    if (normal_) {
      normal_[3 * i] = h.nx;
      normal_[3 * i + 1] = h.ny;
      normal_[3 * i + 2] = h.nz;
    }
    if (uv_) {
      uv_[2 * i] = h.u;
      uv_[2 * i + 1] = h.v;
    }
    if (instance_) instance_[i] = h.instance;
    if (primitive_) primitive_[i] = h.primitive;
  }

 private:
  float *depth_, *normal_, *uv_;
  uint32_t *instance_, *primitive_;
};

// Answers in chunks: the core's 32-byte hits of one chunk at a time.
// Returns the warnings, each once.
template <class Take>
std::vector<std::string> query_chunks(core::Pipeline& r, std::vector<rf_pixel_hit>& hits, const float* origins,
                                      const float* directions, size_t n, float tmin, float tmax, bool any_hit,
                                      const core::FrameOptions& options, size_t row_length, Take&& take) {
  const size_t kChunk = core::query_chunk_rays(row_length);
  std::vector<std::string> warnings;
  if (n == 0) r.intersect(origins, directions, 0, tmin, tmax, any_hit, options, nullptr);  // checks tmin, tmax
  for (size_t begin = 0; begin < n; begin += kChunk) {
    const size_t count = std::min(kChunk, n - begin);
    hits.resize(count);
    for (std::string& w :
         r.intersect(origins + 3 * begin, directions + 3 * begin, count, tmin, tmax, any_hit, options, hits.data(),
                     row_length))
      if (std::find(warnings.begin(), warnings.end(), w) == warnings.end()) warnings.push_back(std::move(w));
    take(begin, hits);
  }
  return warnings;
}

}  // namespace

RayHits Renderer::intersect(const float* origins, const float* directions, size_t n, float tmin, float tmax,
                            size_t row_length, unsigned channels) {
  RayHits out;
  intersect_into(out, origins, directions, n, tmin, tmax, row_length, channels);
  return out;
}

void Renderer::intersect_into(RayHits& out, const float* origins, const float* directions, size_t n, float tmin,
                              float tmax, size_t row_length, unsigned channels) {
  check_channels(channels, kAllChannels);
  core::FrameOptions options;
  options.moved = impl_->moved();
  options.normals = (channels & kNormal) != 0;
  out.channels = channels;
  size_planes(channels, n, impl_->options.threads, out.t, out.normal, out.uv, out.instance_id, out.primitive_id);
  const PlaneWriter writer(out.t, out.normal, out.uv, out.instance_id, out.primitive_id);
  out.warnings = query_chunks(
      *impl_->core, impl_->query_hits, origins, directions, n, tmin, tmax, false, options, row_length,
      [&](size_t begin, const std::vector<rf_pixel_hit>& hits) {
        core::parallel_for(hits.size(), impl_->options.threads, size_t{1} << 15, [&](size_t lo, size_t hi) {
          for (size_t k = lo; k < hi; ++k) writer.put(begin + k, hits[k]);
        });
      });
}

std::vector<uint8_t> Renderer::occluded(const float* origins, const float* directions, size_t n, float tmin,
                                        float tmax, std::vector<std::string>* warnings, size_t row_length) {
  core::FrameOptions options;
  options.moved = impl_->moved();
  options.normals = false;
  std::vector<uint8_t> out(n);
  std::vector<std::string> w = query_chunks(
      *impl_->core, impl_->query_hits, origins, directions, n, tmin, tmax, true, options, row_length,
      [&](size_t begin, const std::vector<rf_pixel_hit>& hits) {
        for (size_t k = 0; k < hits.size(); ++k) out[begin + k] = hits[k].instance != RF_INVALID;
      });
  if (warnings) *warnings = std::move(w);
  return out;
}

GBuffer Renderer::render(const Camera& camera, Fold fold, unsigned channels) {
  GBuffer g;
  render_into(g, camera, fold, channels);
  return g;
}

GBuffer Renderer::render(const Camera& camera, Fold fold, unsigned channels, const FlowTo& to) {
  GBuffer g;
  render_into(g, camera, fold, channels, to);
  return g;
}

void Renderer::render_into(GBuffer& g, const Camera& camera, Fold fold, unsigned asked, const FlowTo& to) {
  check_channels(asked, kAnyChannel);
  const unsigned hits = kInstanceId | kPrimitiveId | kBarycentrics;
  const unsigned rest = (asked & ~kFlowChannels) | ((asked & kFlowChannels) ? hits : 0u);
  render_into(g, camera, fold, rest);
  if (!(asked & kFlowChannels)) return;
  detail::SceneState& s = *impl_->state;
  // Posed for the other view, and put back as it was however this ends.
  if (!std::isnan(to.time) && !(to.time == s.time))
    detail::at_pose(s, to.time, "flow to another time", [&] { add_flow(g, to, asked); });
  else
    add_flow(g, to, asked);
  detail::keep_planes(g, asked);
}

void Renderer::add_flow(GBuffer& g, const FlowTo& to, unsigned asked) {
  detail::SceneState& s = *impl_->state;
  const size_t n = static_cast<size_t>(g.width) * g.height;
  core::HitPlanes in;
  in.pixels = n;
  in.instance = g.instance_id.data();
  in.primitive = g.primitive_id.data();
  in.barycentrics = g.uv.data();
  // The points in the other pose, for the visibility's segments.
  std::vector<glm::dvec3> points((asked & kFlowVisible) ? n : 0);
  if (asked & kFlow) g.flow.resize(2 * n);
  core::resolve_flow(s.scene, in, g.width, to.camera.core(), (asked & kFlow) ? g.flow.data() : nullptr,
                     points.empty() ? nullptr : points.data(), impl_->options.threads, s.path);
  if (asked & kFlowVisible) {
    // Seen from the other view: inside its image, and nothing on the
    // segment from its eye (an orthographic view's image plane) short of
    // the point by more than 1e-4 of the segment (t = 1 at the point).
    const core::Camera& other = to.camera.core();
    const core::Projection project_to(other);
    const glm::dvec3 eye = glm::dvec3(other.world_from_camera * glm::dvec4(0.0, 0.0, 0.0, 1.0));
    std::vector<float>& origins = impl_->flow_origins;
    std::vector<float>& directions = impl_->flow_directions;
    std::vector<uint32_t>& pixels = impl_->flow_pixels;
    origins.resize(3 * n);
    directions.resize(3 * n);
    pixels.resize(n);
    g.flow_visible.resize(n);
    // Each chunk writes its segments from its first pixel on, then they are
    // moved together: the order stays the pixels', which keeps neighbouring
    // segments in one vector of the query's lanes.
    constexpr size_t kChunk = size_t{1} << 14;
    std::vector<size_t> counts((n + kChunk - 1) / kChunk, 0);
    core::parallel_for(n, impl_->options.threads, kChunk, [&](size_t begin, size_t end) {
      RF_CHECK_EQ(begin % kChunk, 0u, "parallel_for hands out whole chunks");
      size_t k = begin;
      for (size_t p = begin; p < end; ++p) {
        g.flow_visible[p] = g.instance_id[p] == kMiss ? kMiss : 0u;
        if (g.instance_id[p] == kMiss) continue;
        const glm::dvec2 at = project_to(points[p]);
        if (!(at.x > -0.5 && at.x < other.width - 0.5 && at.y > -0.5 && at.y < other.height - 0.5)) continue;
        glm::dvec3 o = eye;
        if (core::is_orthographic(other)) {
          const glm::dvec3 c = glm::dvec3(other.camera_from_world * glm::dvec4(points[p], 1.0));
          o = glm::dvec3(other.world_from_camera * glm::dvec4(c.x, c.y, 0.0, 1.0));
        }
        const glm::dvec3 d = points[p] - o;
        for (int c = 0; c < 3; ++c) {
          origins[3 * k + c] = static_cast<float>(o[c]);
          directions[3 * k + c] = static_cast<float>(d[c]);
        }
        pixels[k++] = static_cast<uint32_t>(p);
      }
      counts[begin / kChunk] = k - begin;
    });
    size_t m = 0;
    for (size_t c = 0; c < counts.size(); ++c) {
      const size_t from = c * kChunk;
      if (from != m) {
        std::copy_n(&origins[3 * from], 3 * counts[c], &origins[3 * m]);
        std::copy_n(&directions[3 * from], 3 * counts[c], &directions[3 * m]);
        std::copy_n(&pixels[from], counts[c], &pixels[m]);
      }
      m += counts[c];
    }
    if (m > 0) {
      const std::vector<uint8_t> blocked = occluded(origins.data(), directions.data(), m, 0.0f, 1.0f - 1e-4f);
      for (size_t k = 0; k < m; ++k) g.flow_visible[pixels[k]] = blocked[k] ? 0u : 1u;
    }
  }
}

void Renderer::add_no_flow(GBuffer& g, unsigned asked) {
  const size_t n = static_cast<size_t>(g.width) * g.height;
  if (asked & kFlow) {
    g.flow.resize(2 * n);
    for (size_t p = 0; p < n; ++p)
      g.flow[2 * p] = g.flow[2 * p + 1] = g.instance_id[p] == kMiss ? 0.0f : std::numeric_limits<float>::quiet_NaN();
  }
  if (asked & kFlowVisible) {
    g.flow_visible.resize(n);
    for (size_t p = 0; p < n; ++p) g.flow_visible[p] = g.instance_id[p] == kMiss ? kMiss : 0u;
  }
}

GBuffer Renderer::render_at(double time, const Camera& camera, Fold fold, unsigned channels, const FlowTo* to) {
  GBuffer g;
  render_into_at(g, time, camera, fold, channels, to);
  return g;
}

void Renderer::render_into_at(GBuffer& g, double time, const Camera& camera, Fold fold, unsigned channels,
                              const FlowTo* to) {
  auto render = [&] {
    if (to)
      render_into(g, camera, fold, channels, *to);
    else
      render_into(g, camera, fold, channels);
  };
  detail::SceneState& s = *impl_->state;
  if (!(time == s.time) && !(std::isnan(time) && std::isnan(s.time)))
    detail::at_pose(s, time, "render_at", render);
  else
    render();
}

namespace {

// The pixels i < n for which hit(i) holds (hit may also do a pixel's work),
// on `threads` threads in chunks.
template <class Hit>
size_t count_pixels(size_t n, unsigned threads, Hit&& hit) {
  constexpr size_t kChunk = size_t{1} << 15;
  std::vector<size_t> chunk_hits((n + kChunk - 1) / kChunk, 0);
  core::parallel_for(n, threads, kChunk, [&](size_t begin, size_t end) {
    size_t count = 0;
    for (size_t i = begin; i < end; ++i) count += hit(i) ? 1 : 0;
    chunk_hits[begin / kChunk] = count;
  });
  size_t total = 0;
  for (size_t c : chunk_hits) total += c;
  return total;
}

// View `view` of a core result (a pass of one view or more) as the public
// planes asked for, read in place (a copy of the view's hits first cost a
// 720p view 29 MB of fresh memory), on `threads` threads: a 720p frame's 30
// MB of planes cost a fifth of the trace on one. A packed readback's planes
// (core::RenderResult::planes) are already laid out as these: one copy each.
void fill_gbuffer(GBuffer& g, const core::RenderResult& r, size_t view, const std::vector<std::string>& warnings,
                  int width, int height, unsigned threads, unsigned channels, Depth depth_kind, bool exact_depth) {
  const size_t n = static_cast<size_t>(width) * height;
  g.width = width;
  g.height = height;
  g.channels = channels;
  g.depth_kind = depth_kind;
  g.exact_depth = exact_depth;
  size_planes(channels, n, threads, g.depth, g.normal, g.uv, g.instance_id, g.primitive_id);
  g.fold = r.fold;
  g.rays = r.rays;
  g.trace_ms = r.median.trace_ms;
  g.warnings = warnings;
  const core::FrameTimes& t = r.median;
  g.stages = {t.cull_ms, t.tlas_ms, t.upload_ms, t.ray_list_ms, t.trace_ms, t.readback_ms};
  g.top_level = {r.frame_stats.candidates, r.frame_stats.kept, view < r.views.size() ? r.views[view].out_of_range : 0,
                 r.frame_stats.tlas_sah};
  g.kernel = r.kernel;
  g.kernel_reason = r.kernel_reason;
  if (r.readback.in_place) {  // written by the kernel (render_into)
    RF_CHECK_EQ(view, 0u, "planes in place for more than one view");
    const bool by_instance = !g.instance_id.empty();
    RF_CHECK(by_instance || !g.depth.empty(), "planes in place without instance ids or depths to count hits by");
    g.hits = count_pixels(n, threads, [&](size_t i) {
      return by_instance ? g.instance_id[i] != RF_INVALID : g.depth[i] != RF_INF;  // a miss's depth is +inf
    });
    return;
  }
  if (r.readback.channels != 0) {
    RF_CHECK(r.readback.channels == channels && r.readback.words, "packed planes other than those asked for");
    RF_CHECK_LT(r.readback.slot, 0, "planes of a pass still in flight");
    const uint32_t* w = r.readback.words + view * r.readback.words_per_view;
    auto copy = [&](auto& v) {
      if (v.empty()) return;
      std::memcpy(v.data(), w, v.size() * sizeof(uint32_t));
      w += v.size();
    };
    static_assert(sizeof(float) == sizeof(uint32_t), "planes of 32-bit words");
    copy(g.depth);  // in the order of rf_types.h's RF_PLANE_*
    copy(g.normal);
    copy(g.uv);
    copy(g.instance_id);
    copy(g.primitive_id);
    g.hits = r.readback.view_hits.at(view);
    return;
  }
  RF_CHECK(r.hits.size() >= (view + 1) * n, "a view's hits of another size: " + std::to_string(r.hits.size()) +
                                                " hits for view " + std::to_string(view) + " of " + std::to_string(n));
  const rf_pixel_hit* hits = r.hits.data() + view * n;
  const PlaneWriter writer(g.depth, g.normal, g.uv, g.instance_id, g.primitive_id);
  g.hits = count_pixels(n, threads, [&](size_t i) {
    writer.put(i, hits[i]);
    return hits[i].instance != RF_INVALID;
  });
}

// The frame options of a render that asks for these planes.
core::FrameOptions frame_options(Fold fold, std::vector<uint32_t> moved, unsigned channels, bool planar_depth,
                                 bool exact_depth, bool cull) {
  core::FrameOptions frame;
  frame.fold = fold;
  frame.cull = cull;
  frame.moved = std::move(moved);
  frame.normals = (channels & kNormal) != 0;
  frame.planar_depth = planar_depth;
  frame.exact_depth = exact_depth && (channels & kDepth) != 0;
  frame.planes = true;
  frame.channels = channels;
  return frame;
}

static_assert(kDepth == RF_PLANE_DEPTH && kNormal == RF_PLANE_NORMAL && kUv == RF_PLANE_UV &&
                  kInstanceId == RF_PLANE_INSTANCE && kPrimitiveId == RF_PLANE_PRIMITIVE,
              "the public channels are the kernels' plane bits");

}  // namespace

void Renderer::render_into(GBuffer& g, const Camera& camera, Fold fold, unsigned asked) {
  check_channels(asked);
  const auto t0 = core::Clock::now();
  const std::vector<std::string> attribute_warnings = detail::load_attributes(*impl_->state, asked);
  const unsigned channels = detail::trace_channels(asked);
  core::FrameOptions frame =
      frame_options(fold, impl_->moved(), channels, impl_->planar_depth, impl_->exact_depth, impl_->cull);
  core::RenderResult& r = impl_->result;
  // With RAYFOLD_PLANES_IN_PLACE=1 the kernel writes the planes in place
  // where the device can (a CPU device): sized first, as fill_gbuffer leaves
  // them (once they fit); hits counted from the instance ids or the depths.
  // By default it writes 32-byte records that fill_gbuffer copies on the
  // host's threads: 12.8 against 16 ms a 720p frame on Lost Empire, 13.5
  // against 15 to 19 on the conference room, Sponza alike (docs/results.md).
  core::check_host_memory(static_cast<size_t>(camera.width()) * camera.height());
  size_planes(channels, static_cast<size_t>(camera.width()) * camera.height(), impl_->options.threads, g.depth,
              g.normal, g.uv, g.instance_id, g.primitive_id);
  const core::AnswerPlanes targets{data_or_null(g.depth), data_or_null(g.normal), data_or_null(g.uv),
                                   data_or_null(g.instance_id), data_or_null(g.primitive_id)};
  if ((channels & (kInstanceId | kDepth)) && impl_->planes_in_place) frame.planes_in_place = &targets;
  impl_->core->render_into(r, camera.core(), 1, frame);
  fill_gbuffer(g, r, 0, r.warnings, camera.width(), camera.height(), impl_->options.threads, channels,
               impl_->planar_depth ? Depth::planar : Depth::distance, frame.exact_depth);
  g.time = impl_->state->time;
  detail::resolve_gbuffer(g, impl_->state->scene, camera.core(), asked, impl_->options.threads);
  g.warnings.insert(g.warnings.end(), attribute_warnings.begin(), attribute_warnings.end());
  g.frame_ms = core::ms_since(t0);
}

std::vector<GBuffer> Renderer::render_views(const std::vector<Camera>& cameras, Fold fold, int align,
                                           unsigned channels) {
  std::vector<GBuffer> out(cameras.size());
  render_views(cameras, [&](size_t i, GBuffer&& g) { out[i] = std::move(g); }, fold, align, channels);
  return out;
}

void Renderer::render_views(const std::vector<Camera>& cameras, const std::function<void(size_t, GBuffer&&)>& on_view,
                            Fold fold, int align, unsigned channels) {
  render_views(cameras, on_view, fold, align, channels, nullptr);
}

namespace {

void check_align(int align) {
  if (align < 0 || align > kMaxAlignedViews)
    throw InputError("", "align must be 0 (as many as a pass holds) to " + std::to_string(kMaxAlignedViews) + ", not " +
                             std::to_string(align));
}

std::vector<core::Camera> core_cameras(const std::vector<Camera>& cameras) {
  std::vector<core::Camera> views;
  views.reserve(cameras.size());
  for (const Camera& c : cameras) views.push_back(c.core());
  return views;
}

}  // namespace

std::vector<std::vector<size_t>> Renderer::passes(const std::vector<Camera>& cameras, Fold fold, int align) const {
  check_align(align);
  return core::plan_passes(impl_->core->scene_data(), core_cameras(cameras), align == 0 ? kMaxAlignedViews : align,
                           fold);
}

void Renderer::render_views(const std::vector<Camera>& cameras, const std::function<void(size_t, GBuffer&&)>& on_view,
                            Fold fold, int align, unsigned asked,
                            const std::function<void(size_t, GBuffer&)>& prepare) {
  // Flow goes from each view to the next in the list.
  check_channels(asked, kAnyChannel);
  check_align(align);
  if (cameras.empty()) return;
  const bool flow = (asked & kFlowChannels) != 0;
  const unsigned resolved = flow ? (asked & ~kFlowChannels) | kInstanceId | kPrimitiveId | kBarycentrics : asked;
  std::vector<std::string> attribute_warnings = detail::load_attributes(*impl_->state, asked);
  const unsigned channels = detail::trace_channels(asked);
  const core::FrameOptions frame =
      frame_options(fold, impl_->moved(), channels, impl_->planar_depth, impl_->exact_depth, impl_->cull);
  const std::vector<core::Camera> views = core_cameras(cameras);
  const auto passes = core::plan_passes(impl_->core->scene_data(), views, align == 0 ? kMaxAlignedViews : align, fold);
  // Where the device reads packed planes back, pass p + 1 is submitted
  // before pass p's G-buffers are made and handed on, so that the host's
  // work overlaps the device's; elsewhere one pass at a time.
  // (Flow's visibility asks the device too: one pass at a time then.)
  const size_t depth = impl_->core->packs_planes() && !flow ? 2 : 1;
  core::RenderResult* results[2] = {&impl_->result, &impl_->second_result};
  std::vector<core::Clock::time_point> started(passes.size());
  auto submit = [&](size_t p) {
    started[p] = core::Clock::now();
    std::vector<core::Camera> pass_views;
    for (size_t i : passes[p]) pass_views.push_back(views[i]);
    impl_->core->submit_views_into(*results[p % depth], pass_views, frame);
  };
  try {
    if (!passes.empty()) submit(0);
    for (size_t p = 0; p < passes.size(); ++p) {
      core::RenderResult& r = *results[p % depth];
      impl_->core->finish_views(r);
      if (depth == 2 && p + 1 < passes.size()) submit(p + 1);
      const std::vector<size_t>& pass = passes[p];
      const double ms = core::ms_since(started[p]) / static_cast<double>(pass.size());
      for (size_t k = 0; k < pass.size(); ++k) {
        GBuffer g;
        if (prepare) prepare(pass[k], g);
        fill_gbuffer(g, r, k, r.view_warnings.at(k), cameras[pass[k]].width(), cameras[pass[k]].height(),
                     impl_->options.threads, channels, impl_->planar_depth ? Depth::planar : Depth::distance,
                     frame.exact_depth);
        g.time = impl_->state->time;
        detail::resolve_gbuffer(g, impl_->state->scene, views[pass[k]], resolved, impl_->options.threads);
        if (flow) {
          if (pass[k] + 1 < cameras.size())
            add_flow(g, FlowTo{cameras[pass[k] + 1]}, asked);
          else
            add_no_flow(g, asked);
          detail::keep_planes(g, asked);
        }
        // The attributes' warnings go with the first view handed on.
        g.warnings.insert(g.warnings.end(), attribute_warnings.begin(), attribute_warnings.end());
        attribute_warnings.clear();
        g.views_in_trace = static_cast<int>(pass.size());
        g.trace_ms = r.median.trace_ms / static_cast<double>(pass.size());
        g.frame_ms = ms;
        on_view(pass[k], std::move(g));
      }
      if (depth == 1 && p + 1 < passes.size()) submit(p + 1);
    }
  } catch (...) {
    // A pass still in flight is waited for, so its result can be reused.
    for (core::RenderResult* r : results) {
      try {
        impl_->core->finish_views(*r);
      } catch (...) {
      }
    }
    throw;
  }
}

AutoChoice Renderer::choose_fastest(const std::vector<Camera>& cameras, const std::vector<Fold>& folds,
                                    const std::vector<int>& aligns) {
  if (cameras.empty()) throw InputError("", "choose_fastest: no cameras");
  for (int a : aligns)
    if (a < 1 || a > kMaxAlignedViews)
      throw InputError("", "choose_fastest: views per pass must be 1 to " + std::to_string(kMaxAlignedViews) +
                               ", not " + std::to_string(a));
  impl_->moved();  // the trees as the scene is now
  core::Pipeline& p = *impl_->core;
  // The views that align with the first are predicted together; the others
  // go to passes of their own, whose cost the first's stands for.
  std::vector<core::Camera> group;
  for (const Camera& c : cameras)
    if (core::can_align(p.scene_data(), cameras[0].core(), c.core())) group.push_back(c.core());
  std::vector<Fold> fold_list = folds.empty() ? std::vector<Fold>{Fold::none, Fold::y, Fold::x, Fold::xy} : folds;
  std::vector<core::KernelKind> kernels{p.kernel()};
  const bool kernel_free = impl_->options.backend == Backend::opencl && impl_->options.kernel == Kernel::automatic;
  if (kernel_free) kernels = {core::KernelKind::tile, core::KernelKind::single};
  std::vector<int> align_list = aligns;
  if (align_list.empty()) align_list = {1, kMaxAlignedViews};
  if (group.size() == 1) align_list = {1};
  const core::AutoChoice c = core::choose_fastest(p, group, fold_list, kernels, align_list);
  if (kernel_free) p.set_kernel(c.best.kernel, "predicted fastest (docs/cost_model.md)");
  auto kernel_name = [&](core::KernelKind k) {
    return impl_->options.backend == Backend::cpu ? std::string("cpu reference")
                                                  : std::string(k == core::KernelKind::tile ? "tile" : "single");
  };
  AutoChoice out;
  out.fold = c.best.fold;
  out.align = c.best.align;
  out.kernel = kernel_name(c.best.kernel);
  out.probe_ms = c.probe_ms;
  for (const core::Prediction& q : c.predictions)
    out.predictions.push_back({q.choice.fold, kernel_name(q.choice.kernel), q.choice.align, core::choice_name(q.choice),
                               q.trace_ms, q.update_ms});
  return out;
}

BuildStats Renderer::build_stats() const {
  const core::Pipeline& p = *impl_->core;
  return {p.blas_build_ms(), p.scene_data().blas.sah_cost, p.scene_data().blas.max_depth, p.program_build_ms(),
          impl_->builds};
}

std::vector<std::pair<std::string, size_t>> Renderer::device_buffers() const {
  std::vector<std::pair<std::string, size_t>> out;
  for (const core::BufferInfo& b : impl_->core->device_buffers()) out.emplace_back(b.name, b.bytes);
  return out;
}

std::string Renderer::device_name() const { return impl_->core->device_name(); }
std::string Renderer::kernel() const { return impl_->core->kernel_label(); }
unsigned Renderer::tile_lanes() const { return impl_->core->tile_lanes(); }

OpenClPreload::OpenClPreload() : impl_(std::make_unique<core::OpenClPreload>()) {}
OpenClPreload::~OpenClPreload() = default;

std::string opencl_devices() { return core::describe_devices(core::list_devices()); }

}  // namespace rayfold
