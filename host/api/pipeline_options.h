// The public renderer options as the core pipeline's: one translation, for
// Renderer and for the benchmarks that drive the pipeline directly.
#pragma once

#include "pipeline/pipeline.h"
#include "rayfold/renderer.h"

namespace rayfold::detail {

// InputError for a braid out of range, or fast_math with exact_depth. The
// depth options are the frame's, not the pipeline's: not carried.
core::PipelineOptions pipeline_options(const RendererOptions& options);

}  // namespace rayfold::detail
