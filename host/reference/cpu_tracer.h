// The CPU reference tracer: the kernels' own traversal (kernels/rf_trace.h)
// compiled for the host with FP contraction off, so it gives the kernels'
// bits. Multi-threaded over the ray list.
#pragma once

#include "fold/ray_list.h"
#include "reference/trace_inputs.h"

namespace rayfold::core {

// out has camera.width * camera.height entries; every pixel the list covers
// is written. threads = 0: all cores.
void trace_cpu(const TraceInputs& in, const RayList& rays, const rf_camera& camera, rf_pixel_hit* out,
               unsigned threads = 0);

}  // namespace rayfold::core
