#include "reference/cpu_tracer.h"

#include "rf_trace.h"
#include "util/errors.h"
#include "util/parallel.h"

namespace rayfold::core {

void trace_cpu(const TraceInputs& in, const RayList& rays, const rf_camera& camera, const float* depth_scales,
               rf_pixel_hit* out, unsigned threads) {
  RF_CHECK((camera.write_flags & RF_WRITE_EXACT_DEPTH) == 0u || in.depth_xforms != nullptr,
           "an exact-depth trace without its depth table");
  const rf_depth_table depths = in.depth_table();
  const rf_answers answers = rf_answers_in(out);
  parallel_for(rays.entries.size(), threads, 256, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i)
      rf_trace_entry(rays.entries[i], &camera, depth_scales, &depths, in.nodes, in.tris, in.instances, in.normal_xforms,
                     in.tlas_root, &answers, in.alpha_tables());
  });
}

}  // namespace rayfold::core
