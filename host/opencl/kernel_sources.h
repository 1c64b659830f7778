// The OpenCL sources, embedded at build time (tools/cmake/embed_sources.cmake).
#pragma once

#include <string>

namespace rayfold::core {
namespace kernel_text {
extern const char* const rf_common;
extern const char* const rf_types;
extern const char* const rf_geometry;
extern const char* const rf_depth;
extern const char* const rf_alpha;
extern const char* const rf_trace;
extern const char* const rf_lanes;
extern const char* const rf_tile;
extern const char* const rayfold_cl;
extern const char* const rf_unit_tests_cl;
}  // namespace kernel_text

// The shared headers in dependency order, the device-only lane and tile
// headers, then the kernels.
inline std::string trace_program_source() {
  using namespace kernel_text;
  return std::string(rf_common) + rf_types + rf_geometry + rf_depth + rf_alpha + rf_trace + rf_lanes + rf_tile +
         rayfold_cl;
}

// The same plus the single-function wrappers that the unit tests run.
inline std::string unit_test_program_source() { return trace_program_source() + kernel_text::rf_unit_tests_cl; }

}  // namespace rayfold::core
