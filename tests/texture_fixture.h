// Images for the material tests: texels made here, written as PNG bytes
// to put into a glTF's buffer views.
#pragma once

#include <cstdint>
#include <vector>

#include <stb_image_write.h>

namespace rayfold::core::testing {

// An image's texels, RGBA, rows top first.
struct Texels {
  int width = 0, height = 0;
  std::vector<uint8_t> rgba;
  const uint8_t* at(int x, int y) const { return &rgba[(static_cast<size_t>(y) * width + x) * 4]; }
};

inline Texels pattern(int width, int height, uint32_t seed) {
  Texels t{width, height, std::vector<uint8_t>(static_cast<size_t>(width) * height * 4)};
  for (uint8_t& b : t.rgba) {
    seed = seed * 1664525u + 1013904223u;
    b = static_cast<uint8_t>(seed >> 24);
  }
  return t;
}

inline std::vector<uint8_t> png(const Texels& t) {
  std::vector<uint8_t> out;
  stbi_write_png_to_func(
      [](void* context, void* data, int size) {
        auto* o = static_cast<std::vector<uint8_t>*>(context);
        o->insert(o->end(), static_cast<uint8_t*>(data), static_cast<uint8_t*>(data) + size);
      },
      &out, t.width, t.height, 4, t.rgba.data(), t.width * 4);
  return out;
}

}  // namespace rayfold::core::testing
