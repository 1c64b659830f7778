#include "opencl/cl_tracer.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <utility>

#include "opencl/host_buffers.h"
#include "opencl/kernel_sources.h"
#include "util/errors.h"
#include "util/parallel.h"
#include "util/timer.h"

namespace rayfold::core {

unsigned tile_lanes(const DeviceInfo& info, unsigned requested, bool dense_scene) {
  if (requested == 8 || requested == 16) return requested;
  if (const char* env = std::getenv("RAYFOLD_TILE_LANES")) return std::atoi(env) == 8 ? 8 : 16;
  return info.native_float_width >= 16 && !dense_scene ? 16 : 8;
}

const char* kernel_name(KernelKind k) { return k == KernelKind::tile ? "tile" : "single"; }

ClTracer::ClTracer(ClDevice& device, KernelPrecision precision, bool tile_stats, KernelTuning tuning)
    : device_(device), precision_(precision), tile_stats_(tile_stats), tuning_(std::move(tuning)) {
  programs_for(RF_MIRRORS);
}

ClTracer::~ClTracer() {
  // A mapped buffer is unmapped before its release (OpenCL leaves a
  // release of a mapped buffer undefined).
  try {
    device_.queue().finish();
    for (PinnedSlot& p : pinned_)
      if (p.host) read_queue_.enqueueUnmapMemObject(p.pinned, p.host);
    if (read_queue_()) read_queue_.finish();
  } catch (...) {
  }
}

ClTracer::Programs& ClTracer::programs_for(int groups) {
  RF_CHECK(groups >= 1 && groups <= RF_GROUP_LIMIT, "transform group count out of range");
  int size = RF_MIRRORS;
  while (size < groups) size *= 2;
  for (Programs& p : programs_)
    if (p.groups == size) return p;
  std::string defines = "-DRF_LANES=" + std::to_string(tile_lanes()) + " -DRF_MAX_GROUPS=" + std::to_string(size);
  if (tile_stats_) defines += " -DRF_TILE_STATS";
  if (!tuning_.defines.empty()) defines += " " + tuning_.defines;
  if (compiles_with_clang_builtins(device_.info())) defines += " -DRF_CLANG_BUILTINS";
  if (tuning_.alpha_masks) defines += " -DRF_ALPHA";
  Programs p;
  p.groups = size;
  const auto start = Clock::now();
  p.program = device_.build(trace_program_source(), precision_, defines);
  build_ms_ += ms_since(start);
  p.single = cl::Kernel(p.program, "rf_trace_primary");
  p.tile = cl::Kernel(p.program, "rf_trace_tiles");
  p.pack = cl::Kernel(p.program, "rf_pack_planes");
  programs_.push_back(p);
  return programs_.back();
}

void ClTracer::prepare_groups(int groups) { programs_for(groups); }

void ClTracer::upload_scene(const SceneData& data, size_t max_tlas_nodes, size_t max_instances, size_t max_rays,
                            size_t pixel_count) {
  const BlasSet& blas = data.blas;
  blas_node_count_ = static_cast<uint32_t>(blas.nodes.size());
  max_tlas_nodes_ = max_tlas_nodes;
  max_instances_ = max_instances;
  max_rays_ = max_rays;
  pixel_count_ = pixel_count;
  buffer_info_ = {
      {"nodes", at_least_one(blas.nodes.size() + max_tlas_nodes) * sizeof(rf_node)},
      {"triangles", at_least_one(blas.tris.size()) * sizeof(rf_tri)},
      {"instances", at_least_one(max_instances) * sizeof(rf_instance)},
      {"normal_xforms", at_least_one(data.normal_xforms.size()) * sizeof(rf_normal_xform)},
      {"rays", at_least_one(max_rays) * sizeof(uint32_t)},
      {"hits", at_least_one(pixel_count) * sizeof(rf_pixel_hit)},
      {"wide_nodes", at_least_one(data.wide_nodes.size()) * sizeof(rf_wide_node)},
      // Grown by the first frame that asks for the exact depth (upload_frame).
      {"depth_xforms", sizeof(rf_depth_xform)},
  };
  const AlphaTables& alpha = data.alpha;
  // The programs follow the scene's masks (built with RF_ALPHA or not).
  if (tuning_.alpha_masks != !alpha.empty()) {
    tuning_.alpha_masks = !alpha.empty();
    programs_.clear();
  }
  if (tuning_.alpha_masks) {
    buffer_info_.push_back({"alpha_index", alpha.index.size() * sizeof(uint32_t)});
    buffer_info_.push_back({"alpha_triangles", alpha.tris.size() * sizeof(rf_alpha_tri)});
    buffer_info_.push_back({"alpha_images", alpha.images.size() * sizeof(rf_alpha_image)});
    buffer_info_.push_back({"alpha_texels", alpha.texels.size()});
  }
  const DeviceInfo& info = device_.info();
  for (const BufferInfo& b : buffer_info_) {
    if (b.bytes > info.max_alloc_bytes) {
      std::ostringstream s;
      s << "the " << b.name << " buffer needs " << (b.bytes >> 20) << " MiB, more than the largest allocation ("
        << (info.max_alloc_bytes >> 20) << " MiB) that '" << info.name << "' allows";
      throw RuntimeFailure(s.str());
    }
  }
  if (device_bytes() > info.global_mem_bytes) {
    std::ostringstream s;
    s << "the scene and image need " << (device_bytes() >> 20) << " MiB of device memory; '" << info.name << "' has "
      << (info.global_mem_bytes >> 20) << " MiB";
    throw RuntimeFailure(s.str());
  }
  try {
    cl::Context& ctx = device_.context();
    cl::CommandQueue& q = device_.queue();
    nodes_ = cl::Buffer(ctx, CL_MEM_READ_ONLY, buffer_info_[0].bytes);
    tris_ = host_array_buffer(device_, blas.tris, buffer_info_[1].bytes);
    instances_ = cl::Buffer(ctx, CL_MEM_READ_ONLY, buffer_info_[2].bytes);
    normal_xforms_ = cl::Buffer(ctx, CL_MEM_READ_ONLY, buffer_info_[3].bytes);
    depth_scales_ = cl::Buffer(ctx, CL_MEM_READ_ONLY, RF_GROUP_LIMIT * sizeof(float));
    for (RaySlot& r : slots_) r = RaySlot{};
    slots_[0].rays = cl::Buffer(ctx, CL_MEM_READ_ONLY, buffer_info_[4].bytes);
    slots_[0].rays_capacity = at_least_one(max_rays);
    hits_ = cl::Buffer(ctx, CL_MEM_WRITE_ONLY, buffer_info_[5].bytes);
    wide_nodes_ = host_array_buffer(device_, data.wide_nodes, buffer_info_[6].bytes);
    depth_xforms_ = cl::Buffer(ctx, CL_MEM_READ_ONLY, buffer_info_[7].bytes);
    if (tuning_.alpha_masks) {
      auto upload = [&](cl::Buffer& buf, const void* bytes, size_t size) {
        buf = cl::Buffer(ctx, CL_MEM_READ_ONLY, size);
        q.enqueueWriteBuffer(buf, CL_FALSE, 0, size, bytes);
      };
      upload(alpha_bufs_[0], alpha.index.data(), buffer_info_[8].bytes);
      upload(alpha_bufs_[1], alpha.tris.data(), buffer_info_[9].bytes);
      upload(alpha_bufs_[2], alpha.images.data(), buffer_info_[10].bytes);
      upload(alpha_bufs_[3], alpha.texels.data(), buffer_info_[11].bytes);
    }
    depth_xforms_capacity_ = buffer_info_[7].bytes;
    if (!blas.nodes.empty())
      q.enqueueWriteBuffer(nodes_, CL_FALSE, 0, blas.nodes.size() * sizeof(rf_node), blas.nodes.data());
    if (!data.normal_xforms.empty())
      q.enqueueWriteBuffer(normal_xforms_, CL_FALSE, 0, data.normal_xforms.size() * sizeof(rf_normal_xform),
                           data.normal_xforms.data());
    q.finish();
  } catch (const cl::Error& e) {
    throw RuntimeFailure("cannot upload the scene to '" + info.name + "': " + cl_error_text(e));
  }
  ++scene_uploads_;
}

double ClTracer::upload_frame(const Frame& frame) {
  RF_CHECK_EQ(frame.node_base, blas_node_count_, "frame built for another scene upload");
  RF_CHECK(frame.tlas_nodes.size() <= max_tlas_nodes_ && frame.instances.size() <= max_instances_,
           "frame larger than the space reserved for it");
  const auto t0 = Clock::now();
  try {
    cl::CommandQueue& q = device_.queue();
    if (!frame.tlas_nodes.empty())
      q.enqueueWriteBuffer(nodes_, CL_FALSE, blas_node_count_ * sizeof(rf_node),
                           frame.tlas_nodes.size() * sizeof(rf_node), frame.tlas_nodes.data());
    if (!frame.instances.empty())
      q.enqueueWriteBuffer(instances_, CL_FALSE, 0, frame.instances.size() * sizeof(rf_instance),
                           frame.instances.data());
    if (!frame.normal_xforms.empty())
      q.enqueueWriteBuffer(normal_xforms_, CL_FALSE, 0, frame.normal_xforms.size() * sizeof(rf_normal_xform),
                           frame.normal_xforms.data());
    if (!frame.depth_xforms.empty()) {
      const size_t bytes = frame.depth_xforms.size() * sizeof(rf_depth_xform);
      if (bytes > depth_xforms_capacity_) {
        if (bytes > device_.info().max_alloc_bytes)
          throw RuntimeFailure("the exact depth's table of " + std::to_string(frame.views.size()) + " views needs " +
                               std::to_string(bytes >> 20) + " MiB, more than the largest allocation '" +
                               device_.info().name + "' allows");
        depth_xforms_ = cl::Buffer(device_.context(), CL_MEM_READ_ONLY, bytes);
        depth_xforms_capacity_ = bytes;
        buffer_info_[7].bytes = bytes;
      }
      q.enqueueWriteBuffer(depth_xforms_, CL_FALSE, 0, bytes, frame.depth_xforms.data());
    }
    depth_instances_ = frame.depth_instances;
    const std::vector<float> scales = frame.depth_scales();
    RF_CHECK_LE(scales.size(), size_t{RF_GROUP_LIMIT}, "more views than one pass holds");
    q.enqueueWriteBuffer(depth_scales_, CL_FALSE, 0, scales.size() * sizeof(float), scales.data());
    q.finish();
  } catch (const cl::Error& e) {
    throw RuntimeFailure("cannot upload a frame: " + cl_error_text(e));
  }
  tlas_root_ = frame.tlas_root;
  ++frame_uploads_;
  return ms_since(t0);
}

double ClTracer::upload_rays(const RayList& rays, int slot) {
  RF_CHECK_LE(rays.entries.size(), max_rays_, "ray list larger than its buffer");
  RF_CHECK(!rays.tiles.empty() && rays.tiles.back() == rays.entries.size(), "tile table does not cover the rays");
  RF_CHECK(slot >= 0 && slot < kRaySlots, "ray list slot out of range");
  const auto t0 = Clock::now();
  RaySlot& r = slots_[slot];
  try {
    cl::Context& ctx = device_.context();
    if (rays.entries.size() > r.rays_capacity) {
      r.rays = cl::Buffer(ctx, CL_MEM_READ_ONLY, rays.entries.size() * sizeof(uint32_t));
      r.rays_capacity = rays.entries.size();
    }
    // The tile table is small (one entry per 256 rays at most); it grows
    // when an image needs more tiles than any before.
    if (rays.tiles.size() > r.tiles_capacity) {
      r.tiles = cl::Buffer(ctx, CL_MEM_READ_ONLY, rays.tiles.size() * sizeof(uint32_t));
      r.tiles_capacity = rays.tiles.size();
    }
    cl::CommandQueue& q = device_.queue();
    q.enqueueWriteBuffer(r.tiles, CL_FALSE, 0, rays.tiles.size() * sizeof(uint32_t), rays.tiles.data());
    if (!rays.entries.empty())
      q.enqueueWriteBuffer(r.rays, CL_FALSE, 0, rays.entries.size() * sizeof(uint32_t), rays.entries.data());
    q.finish();
  } catch (const cl::Error& e) {
    throw RuntimeFailure("cannot upload the ray list: " + cl_error_text(e));
  }
  r.ray_count = static_cast<uint32_t>(rays.entries.size());
  r.tile_count = static_cast<uint32_t>(rays.tiles.size() - 1);
  slot_ = slot;
  return ms_since(t0);
}

void ClTracer::use_rays(int slot) {
  RF_CHECK(slot >= 0 && slot < kRaySlots, "ray list slot out of range");
  slot_ = slot;
}

double ClTracer::trace(const rf_camera& cam, KernelKind kind) {
  const auto t0 = Clock::now();
  enqueue_trace(cam, kind);
  try {
    device_.queue().finish();
  } catch (const cl::Error& e) {
    throw RuntimeFailure(std::string(kernel_name(kind)) + " trace kernel failed on '" + device_.info().name +
                         "': " + cl_error_text(e));
  }
  return ms_since(t0);
}

namespace {

// A finished command's device time in ms (the queue is profiled).
double device_ms(const cl::Event& e) {
  if (!e()) return 0.0;
  const cl_ulong start = e.getProfilingInfo<CL_PROFILING_COMMAND_START>();
  const cl_ulong end = e.getProfilingInfo<CL_PROFILING_COMMAND_END>();
  return end > start ? static_cast<double>(end - start) * 1e-6 : 0.0;
}

}  // namespace

void ClTracer::enqueue_trace(const rf_camera& cam, KernelKind kind) {
  RF_CHECK_LE(static_cast<size_t>(cam.width) * cam.height * cam.views, pixel_count_, "image larger than the hit buffer");
  last_trace_ = cl::Event();
  const RaySlot& r = slots_[slot_];
  if (r.ray_count == 0) return;
  Programs& programs = programs_for(static_cast<int>(cam.views << cam.group_shift));
  try {
    cl::Kernel& kernel = kind == KernelKind::tile ? programs.tile : programs.single;
    int a = 0;
    kernel.setArg(a++, nodes_);
    if (kind == KernelKind::tile) kernel.setArg(a++, wide_nodes_);
    kernel.setArg(a++, tris_);
    kernel.setArg(a++, instances_);
    kernel.setArg(a++, normal_xforms_);
    kernel.setArg(a++, tlas_root_);
    kernel.setArg(a++, r.rays);
    if (kind == KernelKind::tile) {
      kernel.setArg(a++, r.tiles);
      kernel.setArg(a++, r.tile_count);
    } else {
      kernel.setArg(a++, r.ray_count);
    }
    kernel.setArg(a++, cam.scale_x);
    kernel.setArg(a++, cam.scale_y);
    kernel.setArg(a++, cam.kx0);
    kernel.setArg(a++, cam.ky0);
    kernel.setArg(a++, cam.width);
    kernel.setArg(a++, cam.height);
    kernel.setArg(a++, cam.xpair);
    kernel.setArg(a++, cam.ypair);
    kernel.setArg(a++, cam.frac_x);
    kernel.setArg(a++, cam.frac_y);
    kernel.setArg(a++, cam.ortho);
    kernel.setArg(a++, cam.views);
    kernel.setArg(a++, cam.group_shift);
    kernel.setArg(a++, cam.slot_mirrors);
    kernel.setArg(a++, cam.view_rep);
    kernel.setArg(a++, cam.write_flags);
    kernel.setArg(a++, depth_scales_);
    kernel.setArg(a++, depth_xforms_);
    kernel.setArg(a++, depth_instances_);
    a = planes_bound_ ? set_answer_args(kernel, a, nullptr, plane_bufs_)
                      : set_answer_args(kernel, a, host_out_ ? &host_hits_ : &hits_, nullptr);
    if (kind == KernelKind::tile && tile_stats_) {
      stats_ = cl::Buffer(device_.context(), CL_MEM_WRITE_ONLY,
                          std::max<size_t>(r.tile_count, 1) * RF_TILE_STAT_COUNT * sizeof(uint32_t));
      kernel.setArg(a++, stats_);
    }
    a = set_alpha_args(kernel, a);
    if (kind == KernelKind::tile) {
      // One tile per work-group: the SIMD is inside the work-item.
      device_.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(r.tile_count), cl::NDRange(1),
                                           nullptr, &last_trace_);
    } else {
      constexpr size_t kGroup = 64;
      const size_t global = (r.ray_count + kGroup - 1) / kGroup * kGroup;
      device_.queue().enqueueNDRangeKernel(kernel, cl::NullRange, cl::NDRange(global), cl::NDRange(kGroup), nullptr,
                                           &last_trace_);
    }
  } catch (const cl::Error& e) {
    throw RuntimeFailure(std::string(kernel_name(kind)) + " trace kernel failed on '" + device_.info().name +
                         "': " + cl_error_text(e));
  }
}

namespace {

size_t plane_words(unsigned channels) {
  return ((channels & RF_PLANE_DEPTH) ? 1u : 0u) + ((channels & RF_PLANE_NORMAL) ? 3u : 0u) +
         ((channels & RF_PLANE_UV) ? 2u : 0u) + ((channels & RF_PLANE_INSTANCE) ? 1u : 0u) +
         ((channels & RF_PLANE_PRIMITIVE) ? 1u : 0u);
}

}  // namespace

void ClTracer::enqueue_packed_read(size_t view_pixels, unsigned views, unsigned channels, int slot) {
  RF_CHECK(slot >= 0 && slot < kPackSlots, "packed readback slot out of range");
  RF_CHECK_LE(view_pixels * views, pixel_count_, "packing more hits than the buffer holds");
  RF_CHECK(channels != 0u && (channels & ~RF_PLANE_ALL) == 0u, "packed readback of no or unknown planes");
  RF_CHECK(views >= 1 && views <= RF_GROUP_LIMIT, "packed readback of more views than a pass holds");
  PinnedSlot& pin = pinned_[slot];
  RF_CHECK(!pin.pending, "packed readback slot still being read");
  const size_t words_per_view = plane_words(channels) * view_pixels;
  const size_t words = words_per_view * views;
  const uint32_t groups_per_view = static_cast<uint32_t>((view_pixels + RF_PACK_GROUP - 1) / RF_PACK_GROUP);
  Programs& programs = programs_for(RF_MIRRORS);
  try {
    cl::Context& ctx = device_.context();
    cl::CommandQueue& q = device_.queue();
    if (!read_queue_()) read_queue_ = cl::CommandQueue(ctx, device_.device());
    if (words > pin.capacity) {
      if (pin.host) read_queue_.enqueueUnmapMemObject(pin.pinned, pin.host);
      pin.host = nullptr;
      pin.capacity = 0;
      const size_t bytes = (words + RF_GROUP_LIMIT) * sizeof(uint32_t);
      pin.packed = cl::Buffer(ctx, CL_MEM_READ_WRITE, words * sizeof(uint32_t));
      pin.counts = cl::Buffer(ctx, CL_MEM_READ_WRITE, RF_GROUP_LIMIT * sizeof(uint32_t));
      pin.pinned = cl::Buffer(ctx, CL_MEM_READ_WRITE | CL_MEM_ALLOC_HOST_PTR, bytes);
      pin.host = static_cast<uint32_t*>(
          read_queue_.enqueueMapBuffer(pin.pinned, CL_TRUE, CL_MAP_READ | CL_MAP_WRITE, 0, bytes));
      pin.capacity = words;
    }
    const uint32_t zero = 0;
    q.enqueueFillBuffer(pin.counts, zero, 0, views * sizeof(uint32_t));
    cl::Kernel& k = programs.pack;
    int a = 0;
    k.setArg(a++, host_out_ ? host_hits_ : hits_);
    k.setArg(a++, static_cast<uint32_t>(view_pixels));
    k.setArg(a++, groups_per_view);
    k.setArg(a++, static_cast<uint32_t>(channels));
    k.setArg(a++, static_cast<cl_ulong>(words_per_view));
    k.setArg(a++, pin.packed);
    k.setArg(a++, pin.counts);
    std::vector<cl::Event> packed(1);
    q.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(static_cast<size_t>(groups_per_view) * views * RF_PACK_GROUP),
                           cl::NDRange(RF_PACK_GROUP), nullptr, &packed[0]);
    q.flush();
    // Into the mapped pinned memory: the DMA a GPU does from pinned pages,
    // without the driver's staging copy of pageable ones.
    read_queue_.enqueueReadBuffer(pin.packed, CL_FALSE, 0, words * sizeof(uint32_t), pin.host, &packed);
    read_queue_.enqueueReadBuffer(pin.counts, CL_FALSE, 0, views * sizeof(uint32_t), pin.host + words, &packed,
                                  &pin.done);
    read_queue_.flush();
  } catch (const cl::Error& e) {
    throw RuntimeFailure("cannot read the packed planes back from '" + device_.info().name + "': " + cl_error_text(e));
  }
  pin.words_per_view = words_per_view;
  pin.views = views;
  pin.trace = last_trace_;
  pin.pending = true;
}

ClTracer::PackedPlanes ClTracer::wait_packed(int slot) {
  RF_CHECK(slot >= 0 && slot < kPackSlots, "packed readback slot out of range");
  PinnedSlot& pin = pinned_[slot];
  RF_CHECK(pin.pending, "no packed readback in this slot");
  const auto t0 = Clock::now();
  try {
    pin.done.wait();
  } catch (const cl::Error& e) {
    pin.pending = false;
    throw RuntimeFailure("cannot read the packed planes back from '" + device_.info().name + "': " + cl_error_text(e));
  }
  pin.pending = false;
  PackedPlanes out;
  out.words = pin.host;
  out.hit_counts = pin.host + pin.words_per_view * pin.views;
  out.words_per_view = pin.words_per_view;
  out.wait_ms = ms_since(t0);
  try {
    out.trace_ms = device_ms(pin.trace);
  } catch (const cl::Error&) {
    out.trace_ms = 0.0;  // a device without kernel profiles
  }
  pin.trace = cl::Event();
  return out;
}

int ClTracer::set_answer_args(cl::Kernel& kernel, int a, const cl::Buffer* hits, const cl::Buffer* planes) {
  RF_CHECK(!hits != !planes, "answers go to hits or to planes");
  // A null buffer is a null pointer in the kernel (clSetKernelArg).
  if (hits)
    kernel.setArg(a++, *hits);
  else
    kernel.setArg(a++, sizeof(cl_mem), nullptr);
  for (int p = 0; p < kAnswerPlanes; ++p) {
    if (!planes || !planes[p]())
      kernel.setArg(a++, sizeof(cl_mem), nullptr);
    else
      kernel.setArg(a++, planes[p]);
  }
  return a;
}

bool ClTracer::writes_host_memory() const { return device_.info().is_cpu; }

void ClTracer::bind_planes(const AnswerPlanes* planes, size_t pixel_count) {
  RF_CHECK(writes_host_memory(), "planes bound on a device that does not write host memory");
  RF_CHECK(planes && pixel_count > 0, "no planes to bind");
  host_out_ = nullptr;  // the hits are bound again by bind_output
  host_count_ = 0;
  void* const ptrs[kAnswerPlanes] = {planes->z, planes->normal, planes->uv, planes->instance, planes->primitive};
  const size_t words[kAnswerPlanes] = {1, 3, 2, 1, 1};
  try {
    for (int p = 0; p < kAnswerPlanes; ++p) {
      void* const ptr = ptrs[p];
      const size_t bytes = ptr ? words[p] * pixel_count * sizeof(uint32_t) : 0;
      if (ptr == plane_ptrs_[p] && bytes == plane_bytes_[p]) continue;  // the same memory as last frame
      plane_bufs_[p] =
          ptr ? cl::Buffer(device_.context(), CL_MEM_WRITE_ONLY | CL_MEM_USE_HOST_PTR, bytes, ptr) : cl::Buffer();
      plane_ptrs_[p] = ptr;
      plane_bytes_[p] = bytes;
    }
  } catch (const cl::Error& e) {
    for (int p = 0; p < kAnswerPlanes; ++p) {
      plane_bufs_[p] = cl::Buffer();
      plane_ptrs_[p] = nullptr;
      plane_bytes_[p] = 0;
    }
    planes_bound_ = false;
    throw RuntimeFailure("cannot bind the G-buffer's planes for '" + device_.info().name + "': " + cl_error_text(e));
  }
  planes_bound_ = true;
}

double ClTracer::read_planes() {
  RF_CHECK(planes_bound_, "no planes bound to read");
  const auto t0 = Clock::now();
  try {
    cl::CommandQueue& q = device_.queue();
    for (int p = 0; p < kAnswerPlanes; ++p)
      if (plane_bufs_[p]()) sync_host_buffer(q, plane_bufs_[p], plane_ptrs_[p], plane_bytes_[p]);
    q.finish();
  } catch (const cl::Error& e) {
    planes_bound_ = false;
    throw RuntimeFailure("cannot read the planes back: " + cl_error_text(e));
  }
  // The planes are the caller's memory (numpy's from Python): no trace
  // writes them again until they are bound again.
  planes_bound_ = false;
  return ms_since(t0);
}

void ClTracer::bind_output(rf_pixel_hit* out, size_t pixel_count) {
  RF_CHECK_LE(pixel_count, pixel_count_, "binding more hits than the buffer holds");
  planes_bound_ = false;
  if (host_out_ == out && host_count_ == pixel_count) return;  // the same memory as last frame
  host_out_ = nullptr;
  host_count_ = 0;
  if (!device_.info().is_cpu || pixel_count == 0) return;
  try {
    host_hits_ =
        cl::Buffer(device_.context(), CL_MEM_WRITE_ONLY | CL_MEM_USE_HOST_PTR, pixel_count * sizeof(rf_pixel_hit), out);
    host_out_ = out;
    host_count_ = pixel_count;
  } catch (const cl::Error&) {
    host_out_ = nullptr;  // the device buffer and a copy still work
  }
}

double ClTracer::read_hits(rf_pixel_hit* out, size_t pixel_count) {
  RF_CHECK_LE(pixel_count, pixel_count_, "reading more hits than the buffer holds");
  const auto t0 = Clock::now();
  try {
    cl::CommandQueue& q = device_.queue();
    if (host_out_ == out && pixel_count > 0) {
      // Mapping a host-pointer buffer hands back that memory; it
      // synchronises without a copy on CPU devices.
      void* p = q.enqueueMapBuffer(host_hits_, CL_TRUE, CL_MAP_READ, 0, pixel_count * sizeof(rf_pixel_hit));
      if (p != out) std::memcpy(out, p, pixel_count * sizeof(rf_pixel_hit));
      q.enqueueUnmapMemObject(host_hits_, p);
      q.finish();
    } else {
      q.enqueueReadBuffer(hits_, CL_TRUE, 0, pixel_count * sizeof(rf_pixel_hit), out);
    }
  } catch (const cl::Error& e) {
    throw RuntimeFailure("cannot read the hits back: " + cl_error_text(e));
  }
  return ms_since(t0);
}

std::vector<uint32_t> ClTracer::read_tile_stats() {
  RF_CHECK(tile_stats_, "tracer built without tile statistics");
  std::vector<uint32_t> out(static_cast<size_t>(slots_[slot_].tile_count) * RF_TILE_STAT_COUNT);
  if (!out.empty()) device_.queue().enqueueReadBuffer(stats_, CL_TRUE, 0, out.size() * sizeof(uint32_t), out.data());
  return out;
}

int ClTracer::set_alpha_args(cl::Kernel& kernel, int a) const {
  if (tuning_.alpha_masks)
    for (const cl::Buffer& b : alpha_bufs_) kernel.setArg(a++, b);
  return a;
}

ClTracer::SceneBuffers ClTracer::scene_buffers() const {
  return {nodes_, wide_nodes_, tris_, instances_, normal_xforms_, tlas_root_};
}

std::vector<BufferInfo> ClTracer::buffers() const { return buffer_info_; }

size_t ClTracer::device_bytes() const {
  size_t total = 0;
  for (const BufferInfo& b : buffer_info_) total += b.bytes;
  return total;
}

}  // namespace rayfold::core
