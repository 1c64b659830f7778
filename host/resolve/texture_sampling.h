// Texture lookups for the G-buffer's material channels: a glTF sampler's
// filters and wrap modes over an image's mip chain, at the level of
// detail a ray cone gives (resolve.h says how it is computed).
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec4.hpp>

#include "scene/materials.h"

namespace rayfold::core {

// The image's linear RGBA at texture coordinates `uv` (0 to 1 across the
// image, v downward, as glTF's) at level of detail `lod` (log2 of texels of
// level 0 per pixel footprint; <= 0 magnifies). As OpenGL samples: the mag
// filter where lod <= 0, else the min filter; *_MIPMAP_NEAREST takes level
// ceil(lod + 1/2) - 1, *_MIPMAP_LINEAR blends levels floor(lod) and the
// next by lod's fraction, each clamped to the chain; LINEAR weighs the 2x2
// texels around uv * size - 1/2, NEAREST takes the texel holding uv * size;
// texel indices wrap as the sampler says. sRGB texels are decoded before
// filtering; every sum is in double. A NaN lod samples level 0.
glm::dvec4 sample_texture(const TextureImage& image, const Sampler& sampler, glm::dvec2 uv, double lod);

}  // namespace rayfold::core
