// The compacted ray list: one 4-byte entry per traced ray (kernels/rf_types.h
// documents the bits). Folded lists trace one ray per mirror-partner set;
// pixels without a partner (the centre column or row of odd sizes, the
// asymmetric part of a shifted window) are traced unfolded.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "device_layout.h"
#include "fold/culling.h"
#include "fold/fold.h"

namespace rayfold::core {

struct RayList {
  std::vector<uint32_t> entries;
  // The tile table (kernels/rf_types.h): tile t is entries [tiles[t],
  // tiles[t + 1]), at most RF_TILE_RAYS of them.
  std::vector<uint32_t> tiles;
  size_t pixels = 0;  // pixels answered: width * height
  // Per mirror (fold.h: bit 0 camera x, bit 1 camera y), the bounds of the
  // rays that answer it (for culling); mirrors no ray answers are unused.
  std::array<TracedRegion, RF_MIRRORS> regions{};
  std::array<bool, RF_MIRRORS> group_used{};
};

inline uint32_t encode_ray(int x, int y, bool mirror_x, bool mirror_y) {
  return static_cast<uint32_t>(x) | (static_cast<uint32_t>(y) << RF_RAY_COORD_BITS) |
         (mirror_x ? RF_RAY_MIRROR_X : 0u) | (mirror_y ? RF_RAY_MIRROR_Y : 0u);
}

// The rays to trace for a camera and fold mode, in tiles of RF_TILE_SIDE
// pixels (8x8 blocks of 4x4 quads inside) so that a tile, its vectors, and
// neighbouring work-items of the single-ray kernel trace coherent rays.
RayList make_ray_list(const rf_camera& camera, Fold fold);

// Every stride-th tile of a list (from tile `offset`), with its tile table:
// a sample that keeps the coherence of the full-resolution rays (the
// predictor's probe, renderer.h). Regions and pixels stay the full list's.
RayList sample_tiles(const RayList& rays, size_t stride, size_t offset = 0);

}  // namespace rayfold::core
