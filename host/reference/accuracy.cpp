#include "reference/accuracy.h"

#include <algorithm>
#include <cmath>

#include "util/errors.h"

namespace rayfold::core {

Accuracy measure_accuracy(const std::vector<ReferenceHit>& ref, ConstSpan<rf_pixel_hit> hits) {
  RF_CHECK_EQ(ref.size(), hits.size(), "accuracy: images of different sizes");
  Accuracy a;
  if (ref.empty()) return a;
  size_t same = 0, hit_miss = 0;
  std::vector<double> err;
  for (size_t i = 0; i < ref.size(); ++i) {
    const bool rh = ref[i].instance != RF_INVALID, hh = hits[i].instance != RF_INVALID;
    const bool same_triangle = ref[i].instance == hits[i].instance && ref[i].primitive == hits[i].primitive;
    same += same_triangle;
    hit_miss += rh != hh;
    if (rh && same_triangle)
      err.push_back(std::fabs(static_cast<double>(hits[i].z) - ref[i].distance) / ref[i].distance);
  }
  a.same_hit = static_cast<double>(same) / ref.size();
  a.hit_miss = static_cast<double>(hit_miss) / ref.size();
  if (!err.empty()) {
    std::sort(err.begin(), err.end());
    a.depth_median = err[err.size() / 2];
    a.depth_p99 = err[std::min(err.size() - 1, static_cast<size_t>(0.99 * err.size()))];
    a.depth_max = err.back();
  }
  return a;
}

}  // namespace rayfold::core
