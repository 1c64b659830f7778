// The machine a benchmark figure was measured on. Ratios measured on an AVX2
// CPU do not carry to an AVX-512 one (Embree runs 2.5x faster on Zen 4 than on
// Zen 2, rayfold about the same), so every table names the CPU, its widest
// vector ISA, the OpenCL device with the tile kernel's lanes and Embree's ISA.
#pragma once

#include <string>

namespace rayfold::core {

struct MachineInfo {
  std::string cpu_model;  // /proc/cpuinfo's "model name"; "unknown CPU" where it cannot say
  std::string isa;        // the widest vector ISA the CPU reports: AVX-512, AVX2, AVX, SSE4.2 or "unknown ISA"
};

// Reads the host's CPU from /proc/cpuinfo (x86 Linux; elsewhere the unknowns).
MachineInfo read_machine_info();

// Parses a /proc/cpuinfo text (the first processor's lines); for tests.
MachineInfo parse_cpuinfo(const std::string& text);

// One line for a report: "Intel(R) Xeon(R) ... (AVX-512)".
std::string machine_label(const MachineInfo& m);

}  // namespace rayfold::core
