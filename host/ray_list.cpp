#include "ray_list.h"

#include <algorithm>
#include <climits>

namespace rayfold {
namespace {

// How one column (or row) takes part in a fold.
enum class Role : uint8_t {
  self,  // traced, answers only itself (no partner, or its own partner)
  fold,  // traced, also answers its mirror partner
  skip,  // answered by its partner's ray
};

// k: the ray generator's integer coordinate (2x + kx0, or ky0 - 2y); the
// partner has -k and exists when pair - i is inside the image. `traced_sign`
// picks the half that is traced: k < 0 (left) for columns, k > 0 (top) rows.
std::vector<Role> roles(int n, int k0, int step, int pair, bool fold, int traced_sign) {
  std::vector<Role> r(n, Role::self);
  if (!fold) return r;
  for (int i = 0; i < n; ++i) {
    const int k = k0 + step * 2 * i;
    const int partner = pair - i;
    if (k == 0 || partner < 0 || partner >= n) continue;
    r[i] = (k > 0) == (traced_sign > 0) ? Role::fold : Role::skip;
  }
  return r;
}

void grow(TracedRegion& r, bool& used, int kx, int ky) {
  if (!used) {
    r = {kx, kx, ky, ky};
    used = true;
    return;
  }
  r.kx_min = std::min(r.kx_min, kx);
  r.kx_max = std::max(r.kx_max, kx);
  r.ky_min = std::min(r.ky_min, ky);
  r.ky_max = std::max(r.ky_max, ky);
}

}  // namespace

RayList make_ray_list(const rf_camera& cam, FoldMode fold) {
  const std::vector<Role> cols = roles(cam.width, cam.kx0, 1, cam.xpair, folds_columns(fold), -1);
  const std::vector<Role> rows = roles(cam.height, cam.ky0, -1, cam.ypair, folds_rows(fold), +1);
  constexpr int kSub = 8;
  static_assert(RF_TILE_SIDE % kSub == 0, "tiles are made of whole sub-blocks");
  RayList list;
  list.pixels = static_cast<size_t>(cam.width) * cam.height;
  list.entries.reserve(list.pixels / (fold == FoldMode::none ? 1 : 2) + cam.width + cam.height);
  list.tiles.push_back(0);
  for (int ty = 0; ty < cam.height; ty += RF_TILE_SIDE)
    for (int tx = 0; tx < cam.width; tx += RF_TILE_SIDE) {
      for (int sy = ty; sy < std::min(ty + RF_TILE_SIDE, cam.height); sy += kSub)
        for (int sx = tx; sx < std::min(tx + RF_TILE_SIDE, cam.width); sx += kSub)
          for (int y = sy; y < std::min(sy + kSub, cam.height); ++y) {
            if (rows[y] == Role::skip) continue;
            for (int x = sx; x < std::min(sx + kSub, cam.width); ++x) {
              if (cols[x] == Role::skip) continue;
              const bool mx = cols[x] == Role::fold, my = rows[y] == Role::fold;
              list.entries.push_back(encode_ray(x, y, mx, my));
              const int kx = 2 * x + cam.kx0, ky = cam.ky0 - 2 * y;
              // Group g's instances are mirrored, so a ray answering g meets
              // them exactly where the partner pixel's ray meets the originals.
              grow(list.regions[0], list.group_used[0], kx, ky);
              if (mx) grow(list.regions[1], list.group_used[1], kx, ky);
              if (my) grow(list.regions[2], list.group_used[2], kx, ky);
              if (mx && my) grow(list.regions[3], list.group_used[3], kx, ky);
            }
          }
      if (list.entries.size() != list.tiles.back()) list.tiles.push_back(static_cast<uint32_t>(list.entries.size()));
    }
  return list;
}

}  // namespace rayfold
