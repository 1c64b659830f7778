// Peak resident memory of one step, measured the same way for rayfold and
// its peers: the kernel's high-water mark of this process's resident set
// (VmHWM), reset before the step (/proc/self/clear_refs), less the resident
// set the step started from. Linux only; elsewhere, or where the reset is
// refused, available() is false and the reports leave the column out.
#pragma once

#include <cstddef>

namespace rayfold::core {

class PeakMemory {
 public:
  // Resets the high-water mark and records the current resident set.
  PeakMemory();
  bool available() const { return available_; }
  // Bytes by which the resident set's peak since construction exceeded its
  // size at construction (0 when unavailable).
  size_t peak_bytes() const;

 private:
  bool available_ = false;
  size_t start_ = 0;
};

}  // namespace rayfold::core
