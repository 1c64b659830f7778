#include "ray_list.h"

#include <algorithm>

namespace rayfold {

RayList make_full_ray_list(int width, int height) {
  constexpr int kTile = 8;
  RayList list;
  list.entries.reserve(static_cast<size_t>(width) * height);
  for (int ty = 0; ty < height; ty += kTile)
    for (int tx = 0; tx < width; tx += kTile)
      for (int y = ty; y < std::min(ty + kTile, height); ++y)
        for (int x = tx; x < std::min(tx + kTile, width); ++x) list.entries.push_back(encode_ray(x, y, false, false));
  list.pixels = list.entries.size();
  return list;
}

}  // namespace rayfold
