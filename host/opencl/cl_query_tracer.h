// Ray queries (rays/ray_queries.h) on an OpenCL device, beside the camera
// tracer: they trace through the scene the frame tracer uploaded, in a query
// frame (fold/frame.h, build_query_frame), with buffers of their own for the
// rays, the answers and the query frame's 8-wide trees.
#pragma once

#include <cstdint>
#include <vector>

#include "bvh/wide_bvh.h"
#include "fold/frame.h"
#include "opencl/cl_tracer.h"
#include "rays/ray_queries.h"

namespace rayfold::core {

class ClQueryTracer {
 public:
  // Traces through `frames`' scene, which outlives this tracer.
  explicit ClQueryTracer(ClTracer& frames);
  ClQueryTracer(const ClQueryTracer&) = delete;
  ClQueryTracer& operator=(const ClQueryTracer&) = delete;

  // The bottom levels as the single-ray query kernel walks them
  // (build_query_trees), before the first whole-tree frame's upload; on a
  // CPU device read in place, so kept by the caller until the next scene
  // upload or this tracer's end.
  void upload_query_trees(const Wide8Trees& trees);
  // Whether upload_query_trees ran since the frame tracer's last scene upload.
  bool has_query_trees() const;
  // Uploads a query frame: the frame tracer's part (its top level,
  // instances, normal matrices) and the 8-wide top level and roots of a
  // whole-tree frame; ms.
  double upload_frame(const Frame& frame);

  // A chunk of ray queries as the kernels read it: for the single-ray
  // kernel `records`, in trace space and in the order it traces them
  // (to_trace_space with QueryTiles::scattered); for tiles the
  // caller's world-space arrays, which the tile kernel takes to trace space
  // itself by 2^exponent (rf_query_arrays), with tmin and tmax for all.
  struct QueryRays {
    const std::vector<rf_query_ray>* records = nullptr;
    const float* origins = nullptr;     // count x 3
    const float* directions = nullptr;  // count x 3
    size_t count = 0;
    float tmin = 0.0f, tmax = 0.0f;
    int exponent = 0;
  };
  // Answers ray queries through the query frame uploaded last (here, and no
  // camera frame since), one rf_pixel_hit per ray into out (z = t); ms of
  // kernel time. With tiles (plan_query_tiles: rays of one origin, traced
  // ray k being ray order[k] and answering out[order[k]] when the order is
  // not empty), the query tile kernel answers them from the arrays, closest
  // hits only: an any-hit query's answer, hit or not, is the same; the frame
  // must be the re-braided one. Without, the single-ray kernel traces the
  // records (in plan->scattered's order, rays/ray_order.h) through a frame of
  // whole trees, answering into a staging buffer in that order, put back
  // into `out` here.
  double trace_queries(const QueryRays& rays, bool any_hit, unsigned write_flags, rf_pixel_hit* out,
                       const QueryTiles* tiles = nullptr);

  // The buffers this tracer holds beyond the frame tracer's.
  std::vector<BufferInfo> buffers() const;

 private:
  // A buffer grown to hold `bytes` (never shrunk), its size in info.
  void grow(cl::Buffer& buf, BufferInfo& info, size_t bytes, cl_mem_flags flags, const char* what);

  ClTracer& frames_;
  ClDevice& device_;
  cl::Kernel queries_, query_tiles_;
  // A whole-tree frame's 8-wide top level (Frame::tlas_wide) and its
  // instances' 8-wide roots (Frame::query_wide_roots); the bottom levels'
  // 8-wide trees (upload_query_trees).
  cl::Buffer tlas_wide_, wide_roots_, wide_trees_;
  uint64_t trees_scene_ = 0;  // the frame tracer's scene upload the trees went with; 0: none
  uint32_t tlas_wide_root_ = RF_INVALID;
  uint64_t frame_ = 0;        // the frame tracer's frame upload that was a query frame here; 0: none
  bool whole_trees_ = false;  // that frame is of whole trees, the single-ray kernel's (Frame::whole_trees)
  // Grown as queries need (a device that does not read host memory in place).
  cl::Buffer rays_, hits_, tiles_, order_, origins_, directions_;
  // In buffers()'s order: query_top_level, query_roots, query_trees, then
  // the rays, answers, tiles and order (0 bytes until used).
  enum { kTopLevel, kRoots, kTrees, kRays, kHits, kTiles, kOrder, kOrigins, kDirections, kBufferCount };
  BufferInfo info_[kBufferCount];
  std::vector<rf_pixel_hit> staged_;  // answers in a scattered order (trace_queries)
};

}  // namespace rayfold::core
