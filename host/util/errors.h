// Two error tiers (as in pbrt and Embree):
//  - user errors (bad files, bad command lines, a missing OpenCL device) are
//    exceptions carrying context; the CLI turns them into "error: ..." and an
//    exit code;
//  - internal invariants are RF_CHECK: a failure is a rayfold bug, so it
//    prints where and aborts, in every build type.
#pragma once

#include <stdexcept>
#include <string>

namespace rayfold {

// Bad input: a file that breaks its format, or a value out of range. Exit 2.
class InputError : public std::runtime_error {
 public:
  InputError(const std::string& file, const std::string& what)
      : std::runtime_error(file.empty() ? what : file + ": " + what), file_(file) {}
  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

// A bad command line. Exit 2.
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The machine cannot do what was asked: no OpenCL platform, a kernel that does
// not build, not enough device memory. Exit 3.
class RuntimeFailure : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

[[noreturn]] void check_failed(const char* expr, const char* file, int line, const std::string& msg);

}  // namespace rayfold

#define RF_CHECK(expr, msg)                                                 \
  do {                                                                      \
    if (!(expr)) ::rayfold::check_failed(#expr, __FILE__, __LINE__, (msg)); \
  } while (0)
