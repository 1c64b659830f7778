// The median of a list of timings: what every figure over frames reports.
#pragma once

#include <algorithm>
#include <vector>

namespace rayfold::core {

// The upper median for even counts; 0 for none.
inline double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

}  // namespace rayfold::core
