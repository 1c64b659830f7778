// Comparing two renders of the same view bit for bit: how the tools check
// that a folded render is lossless before reporting anything about it.
#pragma once

#include <cstring>
#include <vector>

#include "device_layout.h"
#include "util/span.h"

namespace rayfold::core {

// Pixels whose hit info differs in any bit (0 for identical renders).
inline size_t count_differing_pixels(ConstSpan<rf_pixel_hit> a, ConstSpan<rf_pixel_hit> b) {
  size_t n = a.size() == b.size() ? 0 : (a.size() > b.size() ? a.size() - b.size() : b.size() - a.size());
  for (size_t i = 0; i < a.size() && i < b.size(); ++i) n += std::memcmp(&a[i], &b[i], sizeof(rf_pixel_hit)) != 0;
  return n;
}

}  // namespace rayfold::core
