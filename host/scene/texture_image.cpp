#include "scene/texture_image.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include <stb_image.h>

#include "util/errors.h"

namespace rayfold::core {
namespace {

// What the first bytes say the format is, for the error that refuses it.
std::string sniff_format(const uint8_t* b, size_t n) {
  auto starts = [&](const char* magic, size_t at = 0) {
    const size_t len = std::strlen(magic);
    return n >= at + len && std::memcmp(b + at, magic, len) == 0;
  };
  if (starts("\x89PNG")) return "PNG";
  if (n >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF) return "JPEG";
  if (starts("RIFF") && starts("WEBP", 8)) return "WebP (EXT_texture_webp)";
  if (starts("\xABKTX 20")) return "KTX2 (KHR_texture_basisu)";
  if (starts("DDS ")) return "DDS (MSFT_texture_dds)";
  if (starts("GIF8")) return "GIF";
  if (starts("BM")) return "BMP";
  return "";
}

}  // namespace

const std::array<double, 256> kSrgbToLinear = [] {
  std::array<double, 256> t{};
  for (int i = 0; i < 256; ++i) {
    const double c = i / 255.0;
    t[i] = c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
  }
  return t;
}();

uint8_t linear_to_srgb(double linear) {
  const std::array<double, 256>& t = kSrgbToLinear;
  if (!(linear > 0.0)) return 0;
  if (linear >= 1.0) return 255;
  // The nearest of the 256 linear values: the first not below, or the one before it.
  const size_t i = static_cast<size_t>(std::lower_bound(t.begin(), t.end(), linear) - t.begin());
  if (i == 0) return 0;
  return static_cast<uint8_t>(linear - t[i - 1] <= t[i] - linear ? i - 1 : i);
}

TextureImage decode_texture_image(const uint8_t* bytes, size_t size, bool srgb, const std::string& file,
                                  const std::string& name) {
  const std::string format = sniff_format(bytes, size);
  if (format != "PNG" && format != "JPEG")
    throw InputError(file, name + " is " + (format.empty() ? "not a PNG or JPEG image" : format) +
                               ": rayfold decodes the PNG and JPEG images glTF's core allows");
  if (size > static_cast<size_t>(INT32_MAX)) throw InputError(file, name + " is larger than 2 GiB");
  int w = 0, h = 0, components = 0;
  uint8_t* pixels = stbi_load_from_memory(bytes, static_cast<int>(size), &w, &h, &components, 4);
  if (!pixels) throw InputError(file, name + " (" + format + ") does not decode: " + stbi_failure_reason());
  TextureImage out;
  out.name = name;
  out.srgb = srgb;
  out.reduced_from_16_bits = stbi_is_16_bit_from_memory(bytes, static_cast<int>(size)) != 0;
  out.levels.resize(1);
  out.levels[0].width = w;
  out.levels[0].height = h;
  out.levels[0].rgba.assign(pixels, pixels + static_cast<size_t>(w) * h * 4);
  stbi_image_free(pixels);
  make_mips(out);
  return out;
}

void make_mips(TextureImage& image) {
  image.levels.resize(1);
  while (image.levels.back().width > 1 || image.levels.back().height > 1) {
    const TextureImage::Level& up = image.levels.back();
    TextureImage::Level down;
    down.width = std::max(1, up.width / 2);
    down.height = std::max(1, up.height / 2);
    down.rgba.resize(static_cast<size_t>(down.width) * down.height * 4);
    const int sx = up.width > 1 ? 2 : 1, sy = up.height > 1 ? 2 : 1;
    for (int y = 0; y < down.height; ++y)
      for (int x = 0; x < down.width; ++x)
        for (int c = 0; c < 4; ++c) {
          // Alpha is never sRGB-encoded.
          const bool encoded = image.srgb && c < 3;
          double sum = 0.0;
          for (int dy = 0; dy < sy; ++dy)
            for (int dx = 0; dx < sx; ++dx) {
              const uint8_t b = up.rgba[(static_cast<size_t>(sy * y + dy) * up.width + (sx * x + dx)) * 4 + c];
              sum += encoded ? srgb_to_linear(b) : b / 255.0;
            }
          const double mean = sum / (sx * sy);
          down.rgba[(static_cast<size_t>(y) * down.width + x) * 4 + c] =
              encoded ? linear_to_srgb(mean) : static_cast<uint8_t>(std::lround(std::clamp(mean, 0.0, 1.0) * 255.0));
        }
    image.levels.push_back(std::move(down));
  }
}

}  // namespace rayfold::core
