// Alpha masks: glTF's alphaMode MASK (2.0, 3.9.4), which changes what a ray
// hits, read at load for the primitives whose material has it (every other
// scene reads nothing for them). What the trace reads (rf_alpha.h) is made
// from these by bvh/alpha_tables.h.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include <glm/vec2.hpp>

namespace rayfold::core {

// One triangle of a mesh that has a masked primitive.
struct AlphaTriangle {
  glm::vec2 uv[3] = {};        // the base colour texture's coordinates, KHR_texture_transform applied
  float alpha[3] = {1, 1, 1};  // baseColorFactor's alpha times COLOR_0's, per corner
  // alphaCutoff; -infinity for a triangle of a primitive that is not MASK
  // (always kept).
  float cutoff = -std::numeric_limits<float>::infinity();
  int32_t image = -1;  // Scene::alpha_images, -1 for a material without a base colour texture
};

// A base colour texture's alpha at level 0, one byte a texel, rows top first.
struct AlphaImage {
  uint32_t width = 0, height = 0;
  int wrap_s = 10497, wrap_t = 10497;  // the sampler's (glTF's codes: REPEAT, CLAMP_TO_EDGE, MIRRORED_REPEAT)
  std::vector<uint8_t> alpha;
};

// Whether any of the triangles is masked (not always kept).
inline bool any_masked(const std::vector<AlphaTriangle>& triangles) {
  for (const AlphaTriangle& a : triangles)
    if (a.cutoff != -std::numeric_limits<float>::infinity()) return true;
  return false;
}

}  // namespace rayfold::core
