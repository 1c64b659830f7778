#include "rays/ray_order.h"

#include <algorithm>
#include <cstdint>
#include <cstring>

#include "util/errors.h"
#include "util/parallel.h"

namespace rayfold::core {
namespace {

constexpr int kCellBits = 4;                           // per axis
constexpr uint32_t kKeys = 1u << (3 * kCellBits + 3);  // 2^15: a 128 KiB count table per part
constexpr uint32_t kSpread[16] = {0x000, 0x001, 0x008, 0x009, 0x040, 0x041, 0x048, 0x049,
                                  0x200, 0x201, 0x208, 0x209, 0x240, 0x241, 0x248, 0x249};  // bit b to bit 3b

constexpr float kCells = static_cast<float>(1 << kCellBits);

// Cells per unit along each axis of the box (lo, hi); 0 on a flat axis,
// whose origins all go to cell 0.
void cell_scale(const float lo[3], const float hi[3], float scale[3]) {
  for (int a = 0; a < 3; ++a) scale[a] = hi[a] > lo[a] ? kCells / (hi[a] - lo[a]) : 0.0f;
}

uint32_t key_in_grid(const float* origin, const float* direction, const float lo[3], const float scale[3]) {
  uint32_t morton = 0, octant = 0;
  for (int a = 0; a < 3; ++a) {
    // Clamped in float before the conversion to an integer, NaN to 0.
    float c = (origin[a] - lo[a]) * scale[a];
    c = c > 0.0f ? c : 0.0f;
    c = c < kCells - 1.0f ? c : kCells - 1.0f;
    morton |= kSpread[static_cast<uint32_t>(c)] << a;
    uint32_t bits;
    std::memcpy(&bits, &direction[a], sizeof bits);
    octant |= (bits >> 31) << a;
  }
  return (morton << 3) | octant;
}

}  // namespace

uint32_t scattered_ray_key(const float* origin, const float* direction, const float lo[3], const float hi[3]) {
  float scale[3];
  cell_scale(lo, hi, scale);
  return key_in_grid(origin, direction, lo, scale);
}

void scattered_ray_order(const float* origins, const float* directions, size_t n, std::vector<uint32_t>& order,
                         unsigned threads) {
  order.clear();
  if (n < kMinOrderedRays) return;
  RF_CHECK_LE(n, UINT32_MAX, "scattered_ray_order: more rays than 32-bit indices name");
  float lo[3], hi[3];
  for (int a = 0; a < 3; ++a) lo[a] = hi[a] = origins[a];
  for (size_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], origins[3 * i + a]);
      hi[a] = std::max(hi[a], origins[3 * i + a]);
    }
  // A stable counting sort in parts side by side: part p's rays of key k go
  // after every ray of a smaller key and after the rays of key k of the
  // parts before p.
  // At most kMaxParts: each part's count table is 128 KiB to clear and sum.
  constexpr size_t kMaxParts = 16;
  const size_t parts =
      std::max<size_t>(1, std::min({size_t{resolve_threads(threads)}, kMaxParts, n / kMinOrderedRays}));
  const size_t part_size = (n + parts - 1) / parts;
  float scale[3];
  cell_scale(lo, hi, scale);
  std::vector<uint32_t> keys(n);
  std::vector<std::vector<uint32_t>> next(parts, std::vector<uint32_t>(kKeys, 0));
  parallel_for(parts, threads, 1, [&](size_t p0, size_t p1) {
    for (size_t p = p0; p < p1; ++p)
      for (size_t i = p * part_size; i < std::min(n, (p + 1) * part_size); ++i) {
        keys[i] = key_in_grid(origins + 3 * i, directions + 3 * i, lo, scale);
        ++next[p][keys[i]];
      }
  });
  uint32_t at = 0;
  for (uint32_t k = 0; k < kKeys; ++k)
    for (size_t p = 0; p < parts; ++p) {
      const uint32_t count = next[p][k];
      next[p][k] = at;
      at += count;
    }
  order.resize(n);
  parallel_for(parts, threads, 1, [&](size_t p0, size_t p1) {
    for (size_t p = p0; p < p1; ++p)
      for (size_t i = p * part_size; i < std::min(n, (p + 1) * part_size); ++i)
        order[next[p][keys[i]]++] = static_cast<uint32_t>(i);
  });
}

}  // namespace rayfold::core
