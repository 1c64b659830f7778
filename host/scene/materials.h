// glTF materials as the G-buffer's resolve reads them: the metallic-
// roughness model's factors and textures, emission, and the decoded images
// with their mip chains. Read only when a render asks for base_color,
// metallic_roughness or emissive (kAttributeMaterialData).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

namespace rayfold::core {

// glTF's sampler constants (OpenGL's enums), as a sampler names them.
enum SamplerFilter : int {
  kNearest = 9728,
  kLinear = 9729,
  kNearestMipmapNearest = 9984,
  kLinearMipmapNearest = 9985,
  kNearestMipmapLinear = 9986,
  kLinearMipmapLinear = 9987,
};
enum SamplerWrap : int { kClampToEdge = 33071, kMirroredRepeat = 33648, kRepeat = 10497 };

// A sampler; where the file leaves a filter undefined (glTF: the
// implementation's choice) rayfold filters linearly between mip levels
// (trilinear) and magnifies linearly.
struct Sampler {
  int mag = kLinear;
  int min = kLinearMipmapLinear;
  int wrap_s = kRepeat, wrap_t = kRepeat;
};

// One decoded image: RGBA at 8 bits per channel (PNG and JPEG decoded by
// stb_image; 16-bit PNGs rounded to 8), its mip chain made once at load.
// Level k + 1 is level k halved (each size rounded down, at least 1), each
// texel the mean of its 2x2 texels of level k (an odd last row or column
// left out) taken in linear values (`srgb`: decoded from sRGB first) and
// encoded back to 8 bits, rounded to nearest: what a GPU's generated mips
// of an sRGB texture hold.
struct TextureImage {
  struct Level {
    int width = 0, height = 0;
    std::vector<uint8_t> rgba;  // rows top first, 4 bytes a texel
  };
  std::string name;  // "image N ('name')", for messages
  bool srgb = false;
  bool reduced_from_16_bits = false;  // a 16-bit PNG, kept at 8 bits a channel as every image is
  std::vector<Level> levels;
};

// A material's texture: which image, how it is sampled and with which
// texture coordinates.
struct TextureRef {
  int image = -1;  // index into Scene::images; -1: the material has no such texture
  Sampler sampler;
  int texcoord = 0;  // TEXCOORD_n set (KHR_texture_transform's texCoord overrides the textureInfo's)
  // KHR_texture_transform: uv' = uv_transform * (u, v, 1) (translation *
  // rotation * scale); the identity without it.
  glm::dmat3 uv_transform{1.0};
};

// One glTF material, as the resolve reads it (glTF 2.0, 3.9). Factors in
// double as the file gives them.
struct Material {
  std::string name;
  glm::dvec4 base_color_factor{1.0};
  TextureRef base_color;  // sRGB-encoded, RGBA
  double metallic_factor = 1.0, roughness_factor = 1.0;
  TextureRef metallic_roughness;  // linear: roughness in G, metallic in B
  glm::dvec3 emissive_factor{0.0};
  double emissive_strength = 1.0;  // KHR_materials_emissive_strength
  TextureRef emissive;             // sRGB-encoded, RGB
  // Linear, tangent-space XYZ in RGB as 2 * value - 1, its x and y scaled
  // by normal_scale. The three above are read with kAttributeMaterialData,
  // this one with kAttributeNormalTexture: each for the channels it feeds.
  TextureRef normal;
  double normal_scale = 1.0;

  // Its textures, each maybe without an image; whether any has one.
  std::array<const TextureRef*, 4> textures() const { return {&base_color, &metallic_roughness, &emissive, &normal}; }
  bool textured() const {
    for (const TextureRef* t : textures())
      if (t->image >= 0) return true;
    return false;
  }
};

// glTF's default material (3.9.6): white, fully metallic and rough, no
// emission; what a primitive without a material shows.
inline const Material& default_material() {
  static const Material kDefault{};
  return kDefault;
}

}  // namespace rayfold::core
