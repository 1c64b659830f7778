// Small, strict command-line parsing helpers: every malformed value is a
// UsageError that names the option.
#pragma once

#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "rayfold/gbuffer.h"  // Fold

namespace rayfold::core {

// A bad command line. Exit 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace rayfold::core

namespace rayfold::core::cli {

class Args {
 public:
  Args(int argc, char** argv, int first);
  bool done() const { return pos_ >= args_.size(); }
  const std::string& peek() const { return args_[pos_]; }
  std::string next() { return args_[pos_++]; }
  // The value after an option, or a UsageError naming the option.
  std::string value(const std::string& option);

 private:
  std::vector<std::string> args_;
  size_t pos_ = 0;
};

// Runs a tool's body and turns rayfold's two error tiers into the exit codes
// every tool shares: 2 for bad input or usage, 3 for runtime failures (no
// device, out of memory, a failed write), each with "error: ..." on stderr;
// 128 + N for signal N (SIGINT 130, SIGTERM 143, SIGHUP 129). The body's
// output files are renamed into place only when it returns 0: a run that
// fails or is interrupted leaves none of them (util/output_transaction.h).
int guarded_main(const std::function<int()>& body);

int parse_int(const std::string& option, const std::string& text, int lo, int hi);
double parse_double(const std::string& option, const std::string& text);
glm::dvec3 parse_vec3(const std::string& option, const std::string& text);
void parse_size(const std::string& option, const std::string& text, int* width, int* height);
// A comma-separated list's items ("a,b" gives a and b; an empty item is a
// UsageError naming the option).
std::vector<std::string> split_list(const std::string& option, const std::string& text);
// none, y, x or xy (yx too).
Fold parse_fold(const std::string& option, const std::string& text);

}  // namespace rayfold::core::cli
