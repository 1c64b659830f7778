// Accuracy of a render against the double-precision reference.
#pragma once

#include <vector>

#include "device_layout.h"
#include "reference/double_reference.h"
#include "util/span.h"

namespace rayfold::core {

struct Accuracy {
  double same_hit = 0.0;  // share of pixels with the reference's (instance, primitive), misses included
  double hit_miss = 0.0;  // share where one hits and the other misses
  // Relative distance error over pixels that hit the reference's triangle:
  // the precision of t. Pixels that hit another surface (near silhouettes,
  // touching objects) are counted in same_hit instead.
  double depth_median = 0.0;
  double depth_p99 = 0.0;
  double depth_max = 0.0;
  double disagree() const { return 1.0 - same_hit; }
};

Accuracy measure_accuracy(const std::vector<ReferenceHit>& reference, ConstSpan<rf_pixel_hit> hits);

}  // namespace rayfold::core
