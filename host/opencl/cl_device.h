// OpenCL device selection and program builds. Any OpenCL 1.2+ device works;
// PoCL (the CPU) is the one every machine has.
#pragma once

#define CL_HPP_TARGET_OPENCL_VERSION 120
#define CL_HPP_MINIMUM_OPENCL_VERSION 120
#define CL_HPP_ENABLE_EXCEPTIONS
#include <CL/opencl.hpp>

#include <string>
#include <vector>

namespace rayfold::core {

enum class KernelPrecision {
  exact,  // correctly rounded divide and sqrt, no contraction: the CPU reference's bits
  fast,   // -cl-fast-relaxed-math -cl-mad-enable: faster, not bit-exact
};

struct DeviceInfo {
  std::string name, vendor, version, platform;
  unsigned compute_units = 0;
  size_t global_mem_bytes = 0;
  size_t max_alloc_bytes = 0;
  bool correctly_rounded_divide_sqrt = false;
  bool is_cpu = false;              // CL_DEVICE_TYPE_CPU (PoCL): SIMD must come from inside a work-item
  unsigned native_float_width = 1;  // CL_DEVICE_NATIVE_VECTOR_WIDTH_FLOAT: 8 with AVX2, 16 with AVX-512
};

// Whether the kernels compile with clang for a CPU (PoCL's CPU devices), so
// that clang's builtins exist there: prefetch, vector reductions, x86
// instructions where the target has them (RF_CLANG_BUILTINS, kernels/).
bool compiles_with_clang_builtins(const DeviceInfo& info);

// OpenCL drivers keep worker threads (PoCL's pthread device) and driver
// state that a fork does not carry into the child, where the first command
// then waits forever. A child forked after this process (or its parent)
// first used OpenCL gets RuntimeFailure naming the remedies instead of that
// hang. Cheap: one getpid.
void check_not_forked();

class ClDevice {
 public:
  // Picks the device whose platform or device name contains `hint`
  // (case-insensitive), else the environment's RAYFOLD_CL_DEVICE, else the
  // first GPU, else the first device. Throws RuntimeFailure when none exists.
  explicit ClDevice(const std::string& hint = "");

  const DeviceInfo& info() const { return info_; }
  // Each throws RuntimeFailure in a process forked after OpenCL was first
  // used in its parent (check_not_forked).
  cl::Context& context() { return check_not_forked(), context_; }
  cl::Device& device() { return check_not_forked(), device_; }
  cl::CommandQueue& queue() { return check_not_forked(), queue_; }

  // Builds a program with the precision's options and `defines` (for
  // example "-DRF_LANES=8"); a failed build throws RuntimeFailure with the
  // build log.
  cl::Program build(const std::string& source, KernelPrecision precision, const std::string& defines = "");

 private:
  cl::Device device_;
  cl::Context context_;
  cl::CommandQueue queue_;
  DeviceInfo info_;
};

// Loads the OpenCL platforms and their devices on a thread of its own, for
// a caller that will open a device after other work (the command line,
// while it reads the scene): on PoCL that is about 35 ms of dynamic loading
// (its LLVM), which the read then hides. Device openings wait for the load;
// so does the destructor, since a process must not exit (or fork) while a
// thread loads libraries. Once per process: later objects only wait. It
// counts as this process's first use of OpenCL (check_not_forked), so a
// library whose caller may fork afterwards must not make one. Errors are
// left to the opening, which reports them.
class OpenClPreload {
 public:
  OpenClPreload();
  ~OpenClPreload();
  OpenClPreload(const OpenClPreload&) = delete;
  OpenClPreload& operator=(const OpenClPreload&) = delete;
};

// Every OpenCL device of every platform, in platform order; throws
// RuntimeFailure when there is none.
std::vector<DeviceInfo> list_devices();
// One line per device: "  <platform>: <name> (CPU, N compute units, <version>)".
std::string describe_devices(const std::vector<DeviceInfo>& devices);

// "<call>: <OpenCL error name> (<code>)" for messages.
std::string cl_error_text(const cl::Error& e);

}  // namespace rayfold::core
