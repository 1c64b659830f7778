// The CPU reference tracer: the kernels' own traversal (kernels/rf_trace.h)
// compiled for the host with FP contraction off, so it gives the kernels'
// bits. Multi-threaded over the ray list.
#pragma once

#include "fold/ray_list.h"
#include "reference/trace_inputs.h"

namespace rayfold::core {

// out has camera.views * camera.width * camera.height entries (view after
// view); every pixel the list covers is written in every view. depth_scales:
// one per view. threads = 0: all cores.
void trace_cpu(const TraceInputs& in, const RayList& rays, const rf_camera& camera, const float* depth_scales,
               rf_pixel_hit* out, unsigned threads = 0);

}  // namespace rayfold::core
