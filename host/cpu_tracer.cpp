#include "cpu_tracer.h"

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

#include "../kernels/rf_trace.h"

namespace rayfold {

void trace_cpu(const TraceInputs& in, const RayList& rays, const rf_camera& camera, rf_pixel_hit* out,
               unsigned threads) {
  constexpr size_t kChunk = 256;
  const size_t n = rays.entries.size();
  std::atomic<size_t> next{0};
  auto worker = [&] {
    for (size_t begin; (begin = next.fetch_add(kChunk)) < n;) {
      const size_t end = std::min(n, begin + kChunk);
      for (size_t i = begin; i < end; ++i)
        rf_trace_entry(rays.entries[i], &camera, in.nodes, in.tris, in.instances, in.normal_xforms, in.tlas_root,
                       out);
    }
  };
  if (threads == 0) threads = std::max(1u, std::thread::hardware_concurrency());
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
}

}  // namespace rayfold
