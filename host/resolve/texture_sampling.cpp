#include "resolve/texture_sampling.h"

#include <algorithm>
#include <cmath>

#include "scene/texture_image.h"

namespace rayfold::core {
namespace {

int wrap(long long i, int n, int mode) {
  // Inside the image every mode leaves the index as it is: no division.
  if (i >= 0 && i < n) return static_cast<int>(i);
  switch (mode) {
    case kClampToEdge: return static_cast<int>(std::clamp<long long>(i, 0, n - 1));
    case kMirroredRepeat: {
      const long long period = 2LL * n, m = ((i % period) + period) % period;
      return static_cast<int>(m < n ? m : period - 1 - m);
    }
    default: return static_cast<int>(((i % n) + n) % n);
  }
}

glm::dvec4 texel(const TextureImage& image, const TextureImage::Level& level, int x, int y) {
  const uint8_t* t = &level.rgba[(static_cast<size_t>(y) * level.width + x) * 4];
  glm::dvec4 out;
  for (int c = 0; c < 4; ++c) out[c] = image.srgb && c < 3 ? srgb_to_linear(t[c]) : t[c] / 255.0;
  return out;
}

// A coordinate outside any float's reach of the image (a huge uv) still
// indexes a texel: clamped to a range whose wrap is exact in long long.
long long texel_index(double x) { return static_cast<long long>(std::floor(std::clamp(x, -0x1p52, 0x1p52))); }

glm::dvec4 sample_level(const TextureImage& image, size_t l, const Sampler& s, glm::dvec2 uv, bool linear) {
  const TextureImage::Level& level = image.levels[std::min(l, image.levels.size() - 1)];
  const double x = uv.x * level.width, y = uv.y * level.height;
  if (!linear)
    return texel(image, level, wrap(texel_index(x), level.width, s.wrap_s),
                 wrap(texel_index(y), level.height, s.wrap_t));
  const long long x0 = texel_index(x - 0.5), y0 = texel_index(y - 0.5);
  const double fx = (x - 0.5) - static_cast<double>(x0), fy = (y - 0.5) - static_cast<double>(y0);
  const int xa = wrap(x0, level.width, s.wrap_s), xb = wrap(x0 + 1, level.width, s.wrap_s);
  const int ya = wrap(y0, level.height, s.wrap_t), yb = wrap(y0 + 1, level.height, s.wrap_t);
  const glm::dvec4 top = (1.0 - fx) * texel(image, level, xa, ya) + fx * texel(image, level, xb, ya);
  const glm::dvec4 bottom = (1.0 - fx) * texel(image, level, xa, yb) + fx * texel(image, level, xb, yb);
  return (1.0 - fy) * top + fy * bottom;
}

}  // namespace

glm::dvec4 sample_texture(const TextureImage& image, const Sampler& s, glm::dvec2 uv, double lod) {
  if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) uv = glm::dvec2(0.0);
  if (std::isnan(lod) || lod <= 0.0) return sample_level(image, 0, s, uv, s.mag != kNearest);
  const double last = static_cast<double>(image.levels.size() - 1);
  switch (s.min) {
    case kNearest: return sample_level(image, 0, s, uv, false);
    case kLinear: return sample_level(image, 0, s, uv, true);
    case kNearestMipmapNearest:
    case kLinearMipmapNearest: {
      const double level = lod <= 0.5 ? 0.0 : std::min(std::ceil(lod + 0.5) - 1.0, last);
      return sample_level(image, static_cast<size_t>(level), s, uv, s.min == kLinearMipmapNearest);
    }
    default: {  // *_MIPMAP_LINEAR (and a filter the file leaves undefined)
      const bool linear = s.min != kNearestMipmapLinear;
      const double d = std::min(lod, last), d0 = std::floor(d), f = d - d0;
      const glm::dvec4 a = sample_level(image, static_cast<size_t>(d0), s, uv, linear);
      if (f == 0.0) return a;
      return (1.0 - f) * a + f * sample_level(image, static_cast<size_t>(d0) + 1, s, uv, linear);
    }
  }
}

}  // namespace rayfold::core
