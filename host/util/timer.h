// The one wall-clock helper: phase times in milliseconds.
#pragma once

#include <chrono>

namespace rayfold::core {

using Clock = std::chrono::steady_clock;

// Milliseconds from t0 until now.
inline double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

}  // namespace rayfold::core
