// Everything one trace reads, as views into host memory. The CPU reference
// traces straight from these; the OpenCL tracer uploads them.
#pragma once

#include <cstddef>
#include <cstdint>

#include "device_layout.h"
#include "rf_alpha.h"
#include "rf_depth.h"

namespace rayfold::core {

struct TraceInputs {
  const rf_node* nodes = nullptr;  // BLAS nodes followed by the frame's TLAS
  size_t node_count = 0;
  const rf_tri* tris = nullptr;
  size_t tri_count = 0;
  const rf_instance* instances = nullptr;
  size_t instance_count = 0;
  const rf_normal_xform* normal_xforms = nullptr;
  size_t normal_xform_count = 0;
  uint32_t tlas_root = RF_INVALID;
  // The exact depth's table (Frame::depth_xforms); null where the frame
  // writes the float depth.
  const rf_depth_xform* depth_xforms = nullptr;
  uint32_t depth_instances = 0;
  rf_depth_table depth_table() const { return rf_depth_table{depth_xforms, depth_instances}; }
  // The alpha masks (SceneData::alpha); all null for a scene without.
  rf_alpha_tables alpha{nullptr, nullptr, nullptr, nullptr};
  const rf_alpha_tables* alpha_tables() const { return alpha.index ? &alpha : nullptr; }
};

}  // namespace rayfold::core
