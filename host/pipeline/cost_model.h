// The cost model of docs/cost_model.md: ways of tracing a list of views, a
// choice's predicted time per view (Pipeline::predict, in cost_model.cpp),
// and the fastest of them.
#pragma once

#include <string>
#include <vector>

#include "fold/fold.h"
#include "opencl/cl_tracer.h"
#include "scene/camera.h"

namespace rayfold::core {

class Pipeline;

// One way of tracing a list of views: the fold, the OpenCL kernel, and how
// many views per pass (align 1: each alone).
struct Choice {
  Fold fold = Fold::none;
  KernelKind kernel = KernelKind::tile;
  int align = 1;
};
std::string choice_name(const Choice& c);  // "xy/tile/align 8"

// A choice's predicted cost per view (docs/cost_model.md): the trace, from
// a probe over a sample of its tiles, and the update (culling, top-level
// build, upload) of the probe's frame.
struct Prediction {
  Choice choice;
  double trace_ms = 0.0;   // per view
  double update_ms = 0.0;  // per view
  double probe_ms = 0.0;   // what the probe of this choice cost
  double total_ms() const { return trace_ms + update_ms; }
};

// The choice of least predicted time (Pipeline::predict) among every
// combination of the folds, kernels and views per pass given, with every
// prediction, fastest first, for the report.
struct AutoChoice {
  Choice best;
  std::vector<Prediction> predictions;
  double probe_ms = 0.0;  // what predicting cost, all choices together
};
AutoChoice choose_fastest(Pipeline& pipeline, const std::vector<Camera>& views, const std::vector<Fold>& folds,
                          const std::vector<KernelKind>& kernels, const std::vector<int>& aligns);

}  // namespace rayfold::core
