#include "opencl/cl_device.h"

#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdlib>
#include <future>
#include <mutex>
#include <system_error>
#include <vector>

#include "opencl/kernel_cache.h"
#include "util/errors.h"

namespace rayfold::core {
namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

const char* error_name(cl_int code) {
  switch (code) {
    case CL_DEVICE_NOT_FOUND: return "CL_DEVICE_NOT_FOUND";
    case CL_OUT_OF_RESOURCES: return "CL_OUT_OF_RESOURCES";
    case CL_OUT_OF_HOST_MEMORY: return "CL_OUT_OF_HOST_MEMORY";
    case CL_MEM_OBJECT_ALLOCATION_FAILURE: return "CL_MEM_OBJECT_ALLOCATION_FAILURE";
    case CL_BUILD_PROGRAM_FAILURE: return "CL_BUILD_PROGRAM_FAILURE";
    case CL_INVALID_VALUE: return "CL_INVALID_VALUE";
    case CL_INVALID_BUFFER_SIZE: return "CL_INVALID_BUFFER_SIZE";
    case CL_INVALID_KERNEL_ARGS: return "CL_INVALID_KERNEL_ARGS";
    case CL_INVALID_WORK_GROUP_SIZE: return "CL_INVALID_WORK_GROUP_SIZE";
    case CL_PLATFORM_NOT_FOUND_KHR: return "CL_PLATFORM_NOT_FOUND_KHR (no OpenCL platform installed)";
    default: return "OpenCL error";
  }
}

}  // namespace

std::string cl_error_text(const cl::Error& e) {
  return std::string(e.what()) + ": " + error_name(e.err()) + " (" + std::to_string(e.err()) + ")";
}

namespace {

struct Candidate {
  cl::Device device;
  std::string platform;
};

// The process that first used OpenCL; 0 before any use.
std::atomic<pid_t> g_opencl_pid{0};

// Marks this process as the one that first used OpenCL, unless one is.
void mark_first_use() {
  pid_t none = 0;
  g_opencl_pid.compare_exchange_strong(none, ::getpid());
}

// OpenClPreload's load, valid once started.
std::mutex g_loading_mutex;
std::shared_future<void> g_loading;

// Every device of every platform, as the ICD loader lists them; throws
// RuntimeFailure when there is none.
std::vector<Candidate> platform_devices() {
  std::vector<cl::Platform> platforms;
  try {
    cl::Platform::get(&platforms);
  } catch (const cl::Error& e) {
    throw RuntimeFailure("no OpenCL platform found (install pocl-opencl-icd): " + cl_error_text(e));
  }
  std::vector<Candidate> all;
  for (cl::Platform& p : platforms) {
    std::vector<cl::Device> devices;
    try {
      p.getDevices(CL_DEVICE_TYPE_ALL, &devices);
    } catch (const cl::Error&) {
      continue;  // a platform without devices
    }
    for (cl::Device& d : devices) all.push_back({d, p.getInfo<CL_PLATFORM_NAME>()});
  }
  if (all.empty()) throw RuntimeFailure("no OpenCL device found (install pocl-opencl-icd)");
  return all;
}

// Waits for OpenClPreload's load, if one was started.
void wait_for_preload() {
  std::shared_future<void> loading;
  {
    std::lock_guard<std::mutex> lock(g_loading_mutex);
    loading = g_loading;
  }
  if (loading.valid()) loading.wait();
}

// Every device of every platform; throws RuntimeFailure when there is none.
std::vector<Candidate> all_devices() {
  check_not_forked();
  mark_first_use();
  wait_for_preload();  // one thread in the ICD loader's start-up at a time
  return platform_devices();
}

DeviceInfo describe(const Candidate& c) {
  DeviceInfo info;
  const cl::Device& d = c.device;
  info.platform = c.platform;
  info.name = d.getInfo<CL_DEVICE_NAME>();
  info.vendor = d.getInfo<CL_DEVICE_VENDOR>();
  info.version = d.getInfo<CL_DEVICE_VERSION>();
  info.compute_units = d.getInfo<CL_DEVICE_MAX_COMPUTE_UNITS>();
  info.global_mem_bytes = d.getInfo<CL_DEVICE_GLOBAL_MEM_SIZE>();
  info.max_alloc_bytes = d.getInfo<CL_DEVICE_MAX_MEM_ALLOC_SIZE>();
  info.is_cpu = (d.getInfo<CL_DEVICE_TYPE>() & CL_DEVICE_TYPE_CPU) != 0;
  info.native_float_width = d.getInfo<CL_DEVICE_NATIVE_VECTOR_WIDTH_FLOAT>();
  info.correctly_rounded_divide_sqrt =
      (d.getInfo<CL_DEVICE_SINGLE_FP_CONFIG>() & CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT) != 0;
  return info;
}

}  // namespace

void check_not_forked() {
  const pid_t first = g_opencl_pid.load();
  if (first == 0 || first == ::getpid()) return;
  throw RuntimeFailure(
      "OpenCL was first used in process " + std::to_string(first) +
      ", and this process is a fork of it: the OpenCL driver's threads do not survive fork, so the device "
      "would wait forever. Start workers with the 'spawn' or 'forkserver' method (Python: "
      "multiprocessing.get_context('spawn'); PyTorch: DataLoader(..., multiprocessing_context='spawn')), or "
      "use OpenCL only in the workers, or render with backend='cpu' in forked workers");
}

OpenClPreload::OpenClPreload() {
  check_not_forked();
  std::lock_guard<std::mutex> lock(g_loading_mutex);
  if (g_loading.valid()) return;
  mark_first_use();
  try {
    g_loading = std::async(std::launch::async, [] {
                  try {
                    platform_devices();
                  } catch (const RuntimeFailure&) {  // the opening reports it
                  }
                }).share();
  } catch (const std::system_error&) {  // no thread to spare: the opening loads the drivers itself
  }
}

OpenClPreload::~OpenClPreload() { wait_for_preload(); }

bool compiles_with_clang_builtins(const DeviceInfo& info) {
  return info.is_cpu && info.platform.find("Portable Computing Language") != std::string::npos;
}

std::vector<DeviceInfo> list_devices() {
  std::vector<DeviceInfo> out;
  for (const Candidate& c : all_devices()) out.push_back(describe(c));
  return out;
}

std::string describe_devices(const std::vector<DeviceInfo>& devices) {
  std::string s;
  for (const DeviceInfo& d : devices)
    s += "  " + d.platform + ": " + d.name + " (" + (d.is_cpu ? "CPU" : "not a CPU") + ", " +
         std::to_string(d.compute_units) + " compute units, " + d.version + ")\n";
  return s;
}

ClDevice::ClDevice(const std::string& hint_arg) {
  std::string hint = hint_arg;
  if (hint.empty()) {
    if (const char* env = std::getenv("RAYFOLD_CL_DEVICE")) hint = env;
  }
  hint = lower(hint);
  const std::vector<Candidate> all = all_devices();
  const Candidate* chosen = nullptr;
  // "cpu" and "gpu" name a type: a cluster's CPU workers must not take the
  // GPU that the default (a GPU first) would give them.
  const bool by_type = hint == "cpu" || hint == "gpu";
  if (!hint.empty()) {
    for (const Candidate& c : all) {
      const bool match = by_type ? (c.device.getInfo<CL_DEVICE_TYPE>() &
                                    (hint == "gpu" ? CL_DEVICE_TYPE_GPU : CL_DEVICE_TYPE_CPU)) != 0
                                 : lower(c.platform + " " + c.device.getInfo<CL_DEVICE_NAME>()).find(hint) !=
                                       std::string::npos;
      if (match) {
        chosen = &c;
        break;
      }
    }
    if (!chosen) {
      std::vector<DeviceInfo> infos;
      for (const Candidate& c : all) infos.push_back(describe(c));
      std::string list = describe_devices(infos);
      list.pop_back();
      throw RuntimeFailure((by_type ? "no OpenCL device is a " + hint : "no OpenCL device matches '" + hint + "'") +
                           "; the devices are:\n" + list);
    }
  }
  for (const Candidate& c : all)
    if (!chosen && c.device.getInfo<CL_DEVICE_TYPE>() == CL_DEVICE_TYPE_GPU) chosen = &c;
  if (!chosen) chosen = &all.front();

  device_ = chosen->device;
  info_ = describe(*chosen);
  try {
    context_ = cl::Context(device_);
    // Profiled: a pipelined pass (Pipeline::submit_views) takes its trace
    // time from the kernel's event, as no wait brackets it.
    queue_ = cl::CommandQueue(context_, device_, CL_QUEUE_PROFILING_ENABLE);
  } catch (const cl::Error& e) {
    throw RuntimeFailure("cannot open OpenCL device '" + info_.name + "': " + cl_error_text(e));
  }
}

cl::Program ClDevice::build(const std::string& source, KernelPrecision precision, const std::string& defines) {
  check_not_forked();
  std::string options = "-cl-std=CL1.2";
  if (!defines.empty()) options += " " + defines;
  if (precision == KernelPrecision::exact) {
    // Without correctly rounded division the kernels cannot match the host's
    // bits; devices lacking it still run, and the parity tests say so.
    if (info_.correctly_rounded_divide_sqrt) options += " -cl-fp32-correctly-rounded-divide-sqrt";
  } else {
    options += " -cl-fast-relaxed-math -cl-mad-enable -DRF_FAST_MATH";
  }
  // A binary is native code for this device from this driver and this
  // source: all of them name it (PoCL's device name holds its CPU target,
  // its platform version the LLVM it compiles with).
  std::string cache = kernel_cache_dir(), key;
  if (!cache.empty()) {
    try {
      const cl::Platform platform(device_.getInfo<CL_DEVICE_PLATFORM>());
      key = info_.platform + "\n" + platform.getInfo<CL_PLATFORM_VERSION>() + "\n" + info_.vendor + "\n" + info_.name +
            "\n" + info_.version + "\n" + device_.getInfo<CL_DRIVER_VERSION>() + "\n" + options + "\n" + source;
    } catch (const cl::Error&) {
      cache.clear();  // a driver that cannot say its version is not cached
    }
  }
  if (!cache.empty()) {
    const std::vector<unsigned char> binary = load_cached_program(cache, key);
    if (!binary.empty()) {
      try {
        cl::Program cached(context_, {device_}, cl::Program::Binaries{binary});
        cached.build({device_}, options.c_str());
        count_kernel_cache_hit();
        return cached;
      } catch (const cl::Error&) {
        // A binary this driver no longer takes: built from source below and
        // stored again.
      }
    }
  }
  cl::Program program(context_, source);
  try {
    program.build({device_}, options.c_str());
  } catch (const cl::Error& e) {
    std::string log;
    try {
      log = program.getBuildInfo<CL_PROGRAM_BUILD_LOG>(device_);
    } catch (const cl::Error&) {
      log = "(no build log)";
    }
    throw RuntimeFailure("OpenCL kernel build failed on '" + info_.name + "' with options '" + options +
                         "': " + cl_error_text(e) + "\nbuild log:\n" + log);
  }
  if (!cache.empty()) {
    try {
      const std::vector<std::vector<unsigned char>> binaries = program.getInfo<CL_PROGRAM_BINARIES>();
      if (binaries.size() == 1) store_cached_program(cache, key, binaries[0]);
    } catch (const cl::Error&) {
      // A driver that gives no binary is simply not cached.
    }
  }
  return program;
}

}  // namespace rayfold::core
