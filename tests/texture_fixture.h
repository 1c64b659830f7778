// Images for the material tests: texels made here, written as PNG bytes
// to put into a glTF's buffer views.
#pragma once

#include <algorithm>
#include <cstddef>
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

// A 16-bit RGBA PNG (rows top first, 4 values a texel), written by hand
// (stb writes 8 bits only): stored deflate blocks, CRCs and Adler-32.
inline std::vector<uint8_t> png16(int width, int height, const std::vector<uint16_t>& rgba) {
  std::vector<uint8_t> raw;
  for (int y = 0; y < height; ++y) {
    raw.push_back(0);  // filter: none
    for (int i = 0; i < width * 4; ++i) {
      const uint16_t v = rgba[static_cast<size_t>(y) * width * 4 + i];
      raw.push_back(static_cast<uint8_t>(v >> 8));
      raw.push_back(static_cast<uint8_t>(v));
    }
  }
  std::vector<uint8_t> z = {0x78, 0x01};
  for (size_t pos = 0; pos < raw.size();) {
    const size_t n = std::min<size_t>(65535, raw.size() - pos);
    z.push_back(pos + n == raw.size() ? 1 : 0);
    for (uint16_t v : {static_cast<uint16_t>(n), static_cast<uint16_t>(~n)}) {
      z.push_back(static_cast<uint8_t>(v));
      z.push_back(static_cast<uint8_t>(v >> 8));
    }
    z.insert(z.end(), raw.begin() + static_cast<std::ptrdiff_t>(pos),
             raw.begin() + static_cast<std::ptrdiff_t>(pos + n));
    pos += n;
  }
  uint32_t a = 1, b = 0;
  for (uint8_t c : raw) {
    a = (a + c) % 65521;
    b = (b + a) % 65521;
  }
  for (int k = 3; k >= 0; --k) z.push_back(static_cast<uint8_t>(((b << 16) | a) >> (8 * k)));
  std::vector<uint8_t> out = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  auto u32 = [&](uint32_t v) {
    for (int k = 3; k >= 0; --k) out.push_back(static_cast<uint8_t>(v >> (8 * k)));
  };
  auto chunk = [&](const char* kind, const std::vector<uint8_t>& data) {
    u32(static_cast<uint32_t>(data.size()));
    const size_t start = out.size();
    out.insert(out.end(), kind, kind + 4);
    out.insert(out.end(), data.begin(), data.end());
    uint32_t crc = 0xFFFFFFFFu;
    for (size_t i = start; i < out.size(); ++i) {
      crc ^= out[i];
      for (int k = 0; k < 8; ++k) crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
    }
    u32(~crc);
  };
  std::vector<uint8_t> header;
  for (uint32_t v : {static_cast<uint32_t>(width), static_cast<uint32_t>(height)})
    for (int k = 3; k >= 0; --k) header.push_back(static_cast<uint8_t>(v >> (8 * k)));
  header.insert(header.end(), {16, 6, 0, 0, 0});  // 16 bits, RGBA, deflate, no filter method, no interlace
  chunk("IHDR", header);
  chunk("IDAT", z);
  chunk("IEND", {});
  return out;
}

}  // namespace rayfold::core::testing
