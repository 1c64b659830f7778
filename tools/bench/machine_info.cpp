#include "bench/machine_info.h"

#include <fstream>
#include <set>
#include <sstream>

namespace rayfold::core {
namespace {

// The value after "key<spaces>:" on a cpuinfo line, or nothing.
bool field(const std::string& line, const std::string& key, std::string* value) {
  if (line.compare(0, key.size(), key) != 0) return false;
  const size_t colon = line.find(':', key.size());
  if (colon == std::string::npos || line.find_first_not_of(" \t", key.size()) != colon) return false;
  const size_t start = line.find_first_not_of(" \t", colon + 1);
  *value = start == std::string::npos ? "" : line.substr(start);
  return true;
}

}  // namespace

MachineInfo parse_cpuinfo(const std::string& text) {
  MachineInfo m{"unknown CPU", "unknown ISA"};
  std::istringstream in(text);
  std::string line, value;
  std::set<std::string> flags;
  bool have_model = false, have_flags = false;
  while (std::getline(in, line)) {
    if (line.empty() && (have_model || have_flags)) break;  // the first processor only
    if (!have_model && field(line, "model name", &value) && !value.empty()) {
      m.cpu_model = value;
      have_model = true;
    } else if (!have_flags && field(line, "flags", &value)) {
      std::istringstream words(value);
      for (std::string w; words >> w;) flags.insert(w);
      have_flags = true;
    }
  }
  if (flags.count("avx512f"))
    m.isa = "AVX-512";
  else if (flags.count("avx2"))
    m.isa = "AVX2";
  else if (flags.count("avx"))
    m.isa = "AVX";
  else if (flags.count("sse4_2"))
    m.isa = "SSE4.2";
  return m;
}

MachineInfo read_machine_info() {
  std::ifstream f("/proc/cpuinfo");
  if (!f) return {"unknown CPU", "unknown ISA"};
  std::ostringstream s;
  s << f.rdbuf();
  return parse_cpuinfo(s.str());
}

std::string machine_label(const MachineInfo& m) { return m.cpu_model + " (" + m.isa + ")"; }

}  // namespace rayfold::core
