// Images decoded for the G-buffer's textures (scene/materials.h's
// TextureImage), and the sRGB transfer function both ways.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "scene/materials.h"

namespace rayfold::core {

// The sRGB-encoded bytes' linear values (IEC 61966-2-1), exact in double,
// made before main: a texel's decode is one load, inline.
extern const std::array<double, 256> kSrgbToLinear;
inline double srgb_to_linear(uint8_t encoded) { return kSrgbToLinear[encoded]; }
// The byte whose linear value is nearest `linear` (clamped to [0, 1]).
uint8_t linear_to_srgb(double linear);

// Decodes a PNG or JPEG image (the formats glTF's core allows) with its mip
// chain (scene/materials.h). Throws InputError(file, ...) naming `name` and
// the format for anything else (WebP, KTX2, GIF, ...) or bytes that do not
// decode.
TextureImage decode_texture_image(const uint8_t* bytes, size_t size, bool srgb, const std::string& file,
                                  const std::string& name);

// The image's mip chain below level 0 (replacing any levels past it).
void make_mips(TextureImage& image);

}  // namespace rayfold::core
