#include "fold/ray_list.h"

#include <algorithm>
#include <climits>

namespace rayfold::core {
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
  // 16x16 tiles of 8x8 blocks of 4x4 quads, each quad row by row: 8
  // consecutive rays form a 4x2 block and 16 a 4x4 block (the tile kernel's
  // vectors: compact blocks meet fewer triangle edges than rows), 64 an 8x8
  // block (the single-ray kernel's work-groups).
  constexpr int kBlock = 8, kQuad = 4;
  static_assert(RF_TILE_SIDE % kBlock == 0, "tiles are made of whole blocks");
  RayList list;
  list.pixels = static_cast<size_t>(cam.width) * cam.height;
  list.entries.reserve(list.pixels / (fold == FoldMode::none ? 1 : 2) + cam.width + cam.height);
  list.tiles.push_back(0);
  auto add = [&](int x, int y) {
    if (rows[y] == Role::skip || cols[x] == Role::skip) return;
    const bool mx = cols[x] == Role::fold, my = rows[y] == Role::fold;
    list.entries.push_back(encode_ray(x, y, mx, my));
    const int kx = 2 * x + cam.kx0, ky = cam.ky0 - 2 * y;
    // Group g's instances are mirrored, so a ray answering g meets them
    // exactly where the partner pixel's ray meets the originals.
    grow(list.regions[0], list.group_used[0], kx, ky);
    if (mx) grow(list.regions[1], list.group_used[1], kx, ky);
    if (my) grow(list.regions[2], list.group_used[2], kx, ky);
    if (mx && my) grow(list.regions[3], list.group_used[3], kx, ky);
  };
  for (int ty = 0; ty < cam.height; ty += RF_TILE_SIDE)
    for (int tx = 0; tx < cam.width; tx += RF_TILE_SIDE) {
      for (int by = ty; by < std::min(ty + RF_TILE_SIDE, cam.height); by += kBlock)
        for (int bx = tx; bx < std::min(tx + RF_TILE_SIDE, cam.width); bx += kBlock)
          for (int qy = by; qy < std::min(by + kBlock, cam.height); qy += kQuad)
            for (int qx = bx; qx < std::min(bx + kBlock, cam.width); qx += kQuad)
              for (int y = qy; y < std::min(qy + kQuad, cam.height); ++y)
                for (int x = qx; x < std::min(qx + kQuad, cam.width); ++x) add(x, y);
      if (list.entries.size() != list.tiles.back()) list.tiles.push_back(static_cast<uint32_t>(list.entries.size()));
    }
  return list;
}

RayList sample_tiles(const RayList& rays, size_t stride, size_t offset) {
  RayList out;
  out.pixels = rays.pixels;
  out.regions = rays.regions;
  out.group_used = rays.group_used;
  out.tiles.push_back(0);
  for (size_t t = offset; t + 1 < rays.tiles.size(); t += stride) {
    out.entries.insert(out.entries.end(), rays.entries.begin() + rays.tiles[t], rays.entries.begin() + rays.tiles[t + 1]);
    out.tiles.push_back(static_cast<uint32_t>(out.entries.size()));
  }
  return out;
}

}  // namespace rayfold::core
