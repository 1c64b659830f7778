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

// The traced columns (or rows) of one role set: [first, last], or none.
struct Span {
  int first = INT_MAX, last = INT_MIN;
  bool empty() const { return first > last; }
};

Span span_of(const std::vector<Role>& roles, bool folding_only) {
  Span s;
  for (int i = 0; i < static_cast<int>(roles.size()); ++i)
    if (folding_only ? roles[i] == Role::fold : roles[i] != Role::skip) {
      s.first = std::min(s.first, i);
      s.last = i;
    }
  return s;
}

}  // namespace

// Columns and rows take their roles independently, so a ray is traced at
// (x, y) when neither skips, and everything below is counted per column and
// per row instead of per pixel: the regions are products of spans, a tile's
// rays the product of its traced rows and columns. Per pixel this was 10 to
// 20 ms of a 1280x720 render's first frame; now a fraction of one.
RayList make_ray_list(const rf_camera& cam, Fold fold) {
  const int w = cam.width, h = cam.height;
  const std::vector<Role> cols = roles(w, cam.kx0, 1, cam.xpair, folds_columns(fold), -1);
  const std::vector<Role> rows = roles(h, cam.ky0, -1, cam.ypair, folds_rows(fold), +1);
  RayList list;
  list.pixels = static_cast<size_t>(w) * h;

  // Group g's instances are mirrored, so a ray answering g meets them
  // exactly where the partner pixel's ray meets the originals. Group 0 is
  // every ray, 1 those with a column partner, 2 a row partner, 3 both.
  for (int g = 0; g < RF_MIRRORS; ++g) {
    const Span xs = span_of(cols, g & 1), ys = span_of(rows, g & 2);
    list.group_used[g] = !xs.empty() && !ys.empty();
    if (list.group_used[g])
      list.regions[g] = {2 * xs.first + cam.kx0, 2 * xs.last + cam.kx0, cam.ky0 - 2 * ys.last, cam.ky0 - 2 * ys.first};
  }

  // An entry is its column's bits or its row's (encode_ray).
  std::vector<uint32_t> col_bits(w), row_bits(h);
  std::vector<int> traced_cols(w + 1, 0), traced_rows(h + 1, 0);  // prefix counts
  for (int x = 0; x < w; ++x) {
    col_bits[x] = encode_ray(x, 0, cols[x] == Role::fold, false);
    traced_cols[x + 1] = traced_cols[x] + (cols[x] != Role::skip);
  }
  for (int y = 0; y < h; ++y) {
    row_bits[y] = encode_ray(0, y, false, rows[y] == Role::fold);
    traced_rows[y + 1] = traced_rows[y] + (rows[y] != Role::skip);
  }
  list.entries.resize(static_cast<size_t>(traced_cols[w]) * traced_rows[h]);
  list.tiles.push_back(0);

  // 16x16 tiles of 8x8 blocks of 4x4 quads, each quad row by row: 8
  // consecutive rays form a 4x2 block and 16 a 4x4 block (the tile kernel's
  // vectors: compact blocks meet fewer triangle edges than rows), 64 an 8x8
  // block (the single-ray kernel's work-groups).
  constexpr int kBlock = 8, kQuad = 4;
  static_assert(RF_TILE_SIDE % kBlock == 0, "tiles are made of whole blocks");
  uint32_t* out = list.entries.data();
  for (int ty = 0; ty < h; ty += RF_TILE_SIDE)
    for (int tx = 0; tx < w; tx += RF_TILE_SIDE) {
      const int ty_end = std::min(ty + RF_TILE_SIDE, h), tx_end = std::min(tx + RF_TILE_SIDE, w);
      const size_t in_tile =
          static_cast<size_t>(traced_rows[ty_end] - traced_rows[ty]) * (traced_cols[tx_end] - traced_cols[tx]);
      if (in_tile == 0) continue;
      for (int by = ty; by < ty_end; by += kBlock)
        for (int bx = tx; bx < tx_end; bx += kBlock)
          for (int qy = by; qy < std::min(by + kBlock, h); qy += kQuad)
            for (int qx = bx; qx < std::min(bx + kBlock, w); qx += kQuad)
              for (int y = qy; y < std::min(qy + kQuad, h); ++y) {
                if (rows[y] == Role::skip) continue;
                for (int x = qx; x < std::min(qx + kQuad, w); ++x)
                  if (cols[x] != Role::skip) *out++ = col_bits[x] | row_bits[y];
              }
      list.tiles.push_back(static_cast<uint32_t>(out - list.entries.data()));
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
