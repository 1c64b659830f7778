// The compacted ray list: one 4-byte entry per traced ray (kernels/rf_types.h
// documents the bits). The unfolded list holds every pixel.
#pragma once

#include <cstdint>
#include <vector>

#include "device_layout.h"

namespace rayfold {

struct RayList {
  std::vector<uint32_t> entries;
  size_t pixels = 0;  // pixels answered; equals width * height for a full list
};

inline uint32_t encode_ray(int x, int y, bool mirror_x, bool mirror_y) {
  return static_cast<uint32_t>(x) | (static_cast<uint32_t>(y) << RF_RAY_COORD_BITS) |
         (mirror_x ? RF_RAY_MIRROR_X : 0u) | (mirror_y ? RF_RAY_MIRROR_Y : 0u);
}

// One ray per pixel, ordered in 8x8 tiles so that neighbouring work-items
// trace neighbouring, coherent rays.
RayList make_full_ray_list(int width, int height);

}  // namespace rayfold
