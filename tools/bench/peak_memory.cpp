#include "bench/peak_memory.h"

#include <fstream>
#include <string>

namespace rayfold::core {
namespace {

// A "Name:   N kB" line of /proc/self/status in bytes; 0 when absent.
size_t status_bytes(const std::string& name) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.compare(0, name.size() + 1, name + ":") == 0) return std::stoull(line.substr(name.size() + 1)) * 1024;
  return 0;
}

}  // namespace

PeakMemory::PeakMemory() {
  std::ofstream reset("/proc/self/clear_refs");
  reset << "5";  // resets VmHWM to the current resident set
  reset.flush();
  available_ = reset.good() && status_bytes("VmHWM") > 0;
  start_ = status_bytes("VmRSS");
}

size_t PeakMemory::peak_bytes() const {
  if (!available_) return 0;
  const size_t peak = status_bytes("VmHWM");
  return peak > start_ ? peak - start_ : 0;
}

}  // namespace rayfold::core
