// What rayfold throws. Every error is about the library's inputs or the
// machine, never about a command line: InputError for a bad file or value
// (it names the file, when there is one), RuntimeFailure when the machine
// cannot do what was asked. Both are std::runtime_error.
#pragma once

#include <stdexcept>
#include <string>

namespace rayfold {

// Bad input: a file that breaks its format, or a value out of range.
class InputError : public std::runtime_error {
 public:
  InputError(const std::string& file, const std::string& what)
      : std::runtime_error(file.empty() ? what : file + ": " + what), file_(file) {}
  // The file the error is about; empty for a value given in memory.
  const std::string& file() const { return file_; }

 private:
  std::string file_;
};

// The machine cannot do what was asked: no OpenCL platform or no matching
// device, a kernel that does not build, not enough memory.
class RuntimeFailure : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace rayfold
