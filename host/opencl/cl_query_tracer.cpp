#include "opencl/cl_query_tracer.h"

#include <string>

#include "opencl/host_buffers.h"
#include "util/errors.h"
#include "util/parallel.h"
#include "util/timer.h"

namespace rayfold::core {

ClQueryTracer::ClQueryTracer(ClTracer& frames) : frames_(frames), device_(frames.device()) {
  // The query kernels are in the frame tracer's program of one view's
  // groups: no second build.
  const char* names[kBufferCount] = {"query_top_level", "query_roots", "query_trees",   "query_rays",      "query_hits",
                                     "query_tiles",     "query_order", "query_origins", "query_directions"};
  for (int k = 0; k < kBufferCount; ++k) info_[k].name = names[k];
  try {
    const cl::Program& program = frames_.program(RF_MIRRORS);
    queries_ = cl::Kernel(program, "rf_trace_queries");
    query_tiles_ = cl::Kernel(program, "rf_trace_query_tiles");
    // The single-ray kernel's tree arguments exist before a frame fills
    // them (a scene of no instances fills none).
    grow(tlas_wide_, info_[kTopLevel], sizeof(rf_wide8_node), CL_MEM_READ_ONLY, "top level");
    grow(wide_roots_, info_[kRoots], sizeof(uint32_t), CL_MEM_READ_ONLY, "instance roots");
    grow(wide_trees_, info_[kTrees], sizeof(rf_wide8_node), CL_MEM_READ_ONLY, "trees");
  } catch (const cl::Error& e) {
    throw RuntimeFailure("cannot prepare ray queries on '" + device_.info().name + "': " + cl_error_text(e));
  }
}

void ClQueryTracer::grow(cl::Buffer& buf, BufferInfo& info, size_t bytes, cl_mem_flags flags, const char* what) {
  if (bytes <= info.bytes && buf()) return;
  if (bytes > device_.info().max_alloc_bytes)
    throw RuntimeFailure(std::string("a query's ") + what + " needs " + std::to_string(bytes >> 20) +
                         " MiB, more than the largest allocation '" + device_.info().name + "' allows");
  buf = cl::Buffer(device_.context(), flags, bytes);
  info.bytes = bytes;
}

void ClQueryTracer::upload_query_trees(const Wide8Trees& trees) {
  const size_t bytes = at_least_one(trees.nodes.size()) * sizeof(rf_wide8_node);
  const DeviceInfo& info = device_.info();
  if (bytes > info.max_alloc_bytes)
    throw RuntimeFailure("the query trees need " + std::to_string(bytes >> 20) +
                         " MiB, more than the largest allocation '" + info.name + "' allows");
  try {
    wide_trees_ = host_array_buffer(device_, trees.nodes, bytes);
    device_.queue().finish();
  } catch (const cl::Error& e) {
    throw RuntimeFailure("cannot upload the query trees to '" + info.name + "': " + cl_error_text(e));
  }
  info_[kTrees].bytes = bytes;
  trees_scene_ = frames_.scene_uploads();
}

bool ClQueryTracer::has_query_trees() const { return trees_scene_ != 0 && trees_scene_ == frames_.scene_uploads(); }

double ClQueryTracer::upload_frame(const Frame& frame) {
  RF_CHECK(frame.query, "a camera frame uploaded as a query frame");
  double ms = frames_.upload_frame(frame);
  const auto t0 = Clock::now();
  try {
    cl::CommandQueue& q = device_.queue();
    auto put = [&](const auto& v, cl::Buffer& buf, BufferInfo& info, const char* what) {
      if (v.empty()) return;
      const size_t bytes = v.size() * sizeof(v[0]);
      grow(buf, info, bytes, CL_MEM_READ_ONLY, what);
      q.enqueueWriteBuffer(buf, CL_FALSE, 0, bytes, v.data());
    };
    put(frame.tlas_wide, tlas_wide_, info_[kTopLevel], "top level");
    put(frame.query_wide_roots, wide_roots_, info_[kRoots], "instance roots");
    q.finish();
  } catch (const cl::Error& e) {
    throw RuntimeFailure("cannot upload a query frame: " + cl_error_text(e));
  }
  tlas_wide_root_ = frame.tlas_wide_root;
  whole_trees_ = frame.whole_trees;
  frame_ = frames_.frame_uploads();
  return ms + ms_since(t0);
}

std::vector<BufferInfo> ClQueryTracer::buffers() const { return {info_, info_ + kBufferCount}; }

double ClQueryTracer::trace_queries(const QueryRays& rays, bool any_hit, unsigned write_flags, rf_pixel_hit* out,
                                    const QueryTiles* plan) {
  const size_t n = rays.count;
  if (n == 0) return 0.0;
  // The query kernel reads RF_INVALID as a top level whose root is a leaf,
  // which only a query frame's tlas_wide_root means.
  RF_CHECK(frame_ != 0 && frame_ == frames_.frame_uploads(), "ray queries traced in a frame that is not a query frame");
  const std::vector<uint32_t>* tiles = plan && !plan->tiles.empty() ? &plan->tiles : nullptr;
  RF_CHECK(tiles || has_query_trees(), "ray queries traced before the query trees' upload");
  // The single-ray kernel reads the whole-tree frame's roots; the tile
  // kernel the re-braided frame's 4-wide ones.
  RF_CHECK(tiles ? !whole_trees_ : whole_trees_, "ray queries traced through a frame built for the other kernel");
  RF_CHECK(!tiles || (tiles->size() >= 2 && tiles->front() == 0 && tiles->back() == n),
           "query tiles do not cover the rays");
  RF_CHECK(tiles ? rays.origins && rays.directions : rays.records && rays.records->size() == n,
           "query rays not in the form their kernel reads");
  // The tile kernel's order, or the order the single-ray kernel takes the
  // rays in.
  static const std::vector<uint32_t> input_order;
  const std::vector<uint32_t>& order = !plan ? input_order : tiles ? plan->order : plan->scattered;
  RF_CHECK(order.empty() || order.size() == n, "query order of another length");
  const auto t0 = Clock::now();
  const size_t ray_bytes = n * sizeof(rf_query_ray), hit_bytes = n * sizeof(rf_pixel_hit);
  const size_t array_bytes = 3 * n * sizeof(float);
  try {
    cl::Context& ctx = device_.context();
    cl::CommandQueue& q = device_.queue();
    // On a CPU device the kernel reads the rays and writes the answers in
    // place (buffers over the caller's memory): a million rays' two 32 MB
    // copies were a fifth of a query. Elsewhere, device buffers and copies.
    cl::Buffer rays_buf, origins_buf, directions_buf, hits_buf;
    // The single-ray kernel in an order answers in that order (into
    // `answers`), put back into `out` below.
    const bool staged = !order.empty() && !tiles;
    if (staged) staged_.resize(n);
    rf_pixel_hit* answers = staged ? staged_.data() : out;
    const bool in_place = device_.info().is_cpu;
    if (in_place) {
      constexpr cl_mem_flags kIn = CL_MEM_READ_ONLY | CL_MEM_USE_HOST_PTR;
      if (tiles) {
        origins_buf = cl::Buffer(ctx, kIn, array_bytes, const_cast<float*>(rays.origins));
        directions_buf = cl::Buffer(ctx, kIn, array_bytes, const_cast<float*>(rays.directions));
      } else {
        rays_buf = cl::Buffer(ctx, kIn, ray_bytes, const_cast<rf_query_ray*>(rays.records->data()));
      }
      hits_buf = cl::Buffer(ctx, CL_MEM_WRITE_ONLY | CL_MEM_USE_HOST_PTR, hit_bytes, answers);
    } else {
      grow(hits_, info_[kHits], hit_bytes, CL_MEM_WRITE_ONLY, "answers");
      if (tiles) {
        grow(origins_, info_[kOrigins], array_bytes, CL_MEM_READ_ONLY, "origins");
        grow(directions_, info_[kDirections], array_bytes, CL_MEM_READ_ONLY, "directions");
        q.enqueueWriteBuffer(origins_, CL_FALSE, 0, array_bytes, rays.origins);
        q.enqueueWriteBuffer(directions_, CL_FALSE, 0, array_bytes, rays.directions);
        origins_buf = origins_;
        directions_buf = directions_;
      } else {
        grow(rays_, info_[kRays], ray_bytes, CL_MEM_READ_ONLY, "rays");
        q.enqueueWriteBuffer(rays_, CL_FALSE, 0, ray_bytes, rays.records->data());
        rays_buf = rays_;
      }
      hits_buf = hits_;
    }
    // The single-ray kernel's records come in the traced order already
    // (to_trace_space); the tile kernel reads the arrays through it.
    const bool ordered = !order.empty() && tiles;
    if (ordered) grow(order_, info_[kOrder], order.size() * sizeof(uint32_t), CL_MEM_READ_ONLY, "order");
    if (ordered) q.enqueueWriteBuffer(order_, CL_FALSE, 0, order.size() * sizeof(uint32_t), order.data());
    if (tiles) {
      grow(tiles_, info_[kTiles], tiles->size() * sizeof(uint32_t), CL_MEM_READ_ONLY, "tiles");
      q.enqueueWriteBuffer(tiles_, CL_FALSE, 0, tiles->size() * sizeof(uint32_t), tiles->data());
      cl::Kernel& kernel = query_tiles_;
      const ClTracer::SceneBuffers scene = frames_.scene_buffers();
      int a = 0;
      kernel.setArg(a++, scene.nodes);
      kernel.setArg(a++, scene.wide_nodes);
      kernel.setArg(a++, scene.tris);
      kernel.setArg(a++, scene.instances);
      kernel.setArg(a++, scene.normal_xforms);
      kernel.setArg(a++, scene.tlas_root);
      kernel.setArg(a++, origins_buf);
      kernel.setArg(a++, directions_buf);
      kernel.setArg(a++, rays.tmin);
      kernel.setArg(a++, rays.tmax);
      kernel.setArg(a++, static_cast<cl_int>(rays.exponent));
      kernel.setArg(a++, tiles_);
      kernel.setArg(a++, static_cast<uint32_t>(tiles->size() - 1));
      kernel.setArg(a++, static_cast<uint32_t>(write_flags));
      kernel.setArg(a++, ordered ? order_ : tiles_);  // read only when ordered
      kernel.setArg(a++, static_cast<uint32_t>(ordered ? 1u : 0u));
      kernel.setArg(a++, hits_buf);
      frames_.set_alpha_args(kernel, a);
      // One tile per work-group, as the camera tile kernel.
      q.enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(tiles->size() - 1), cl::NDRange(1));
    } else {
      cl::Kernel& kernel = queries_;
      const ClTracer::SceneBuffers scene = frames_.scene_buffers();
      int a = 0;
      kernel.setArg(a++, scene.nodes);
      kernel.setArg(a++, wide_trees_);
      kernel.setArg(a++, tlas_wide_);
      kernel.setArg(a++, tlas_wide_root_);
      kernel.setArg(a++, wide_roots_);
      kernel.setArg(a++, scene.tris);
      kernel.setArg(a++, scene.instances);
      kernel.setArg(a++, scene.normal_xforms);
      kernel.setArg(a++, scene.tlas_root);
      kernel.setArg(a++, rays_buf);
      kernel.setArg(a++, static_cast<uint32_t>(n));
      kernel.setArg(a++, static_cast<uint32_t>(any_hit ? 1u : 0u));
      kernel.setArg(a++, static_cast<uint32_t>(write_flags));
      kernel.setArg(a++, hits_buf);
      frames_.set_alpha_args(kernel, a);
      constexpr size_t kGroup = 64;
      const size_t global = (n + kGroup - 1) / kGroup * kGroup;
      q.enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(global), cl::NDRange(kGroup));
    }
    if (in_place) {
      sync_host_buffer(q, hits_buf, answers, hit_bytes);
      q.finish();
    } else {
      q.enqueueReadBuffer(hits_buf, CL_TRUE, 0, hit_bytes, answers);
    }
    if (staged)
      parallel_for(n, 0, size_t{1} << 15, [&](size_t lo, size_t hi) {
        for (size_t k = lo; k < hi; ++k) out[order[k]] = answers[k];
      });
  } catch (const cl::Error& e) {
    // Writes queued without waiting read the caller's rays and this
    // tracer's order: let them end before those can go.
    try {
      device_.queue().finish();
    } catch (const cl::Error&) {
    }
    throw RuntimeFailure("ray query kernel failed on '" + device_.info().name + "': " + cl_error_text(e));
  }
  return ms_since(t0);
}

}  // namespace rayfold::core
