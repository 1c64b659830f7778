// Alpha masks (scene/alpha_mask.h): read at load for the primitives whose
// material is alphaMode MASK, since they change what a ray hits.
#include <cmath>

#include "scene/gltf/loader.h"

namespace rayfold::core::gltf {

const Loader::AlphaMaterial* Loader::mask_of(int material) {
  if (material < 0 || static_cast<size_t>(material) >= model_.materials.size()) return nullptr;
  const auto found = alpha_materials_.find(material);
  if (found != alpha_materials_.end()) return found->second ? &*found->second : nullptr;
  const tinygltf::Material& m = model_.materials[material];
  const std::string where = "material " + std::to_string(material) + (m.name.empty() ? "" : " ('" + m.name + "')");
  std::optional<AlphaMaterial> mask;
  if (m.alphaMode == "BLEND") {
    warn(where + " has alphaMode BLEND: traced as opaque (rayfold traces OPAQUE and MASK)");
  } else if (m.alphaMode == "MASK") {
    AlphaMaterial a;
    a.cutoff = m.alphaCutoff;
    if (!(a.cutoff >= 0.0) || !std::isfinite(a.cutoff))
      fail(where + ": alphaCutoff must be a finite number >= 0, not " + std::to_string(a.cutoff));
    const tinygltf::PbrMetallicRoughness& pbr = m.pbrMetallicRoughness;
    if (pbr.baseColorFactor.size() != 4) fail(where + ": baseColorFactor must have 4 numbers");
    a.factor = pbr.baseColorFactor[3];
    if (!std::isfinite(a.factor)) fail(where + " has a factor that is not finite");
    a.texture = texture_ref(pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord, pbr.baseColorTexture.extensions,
                            true, where + "'s baseColorTexture");
    if (a.texture.image >= 0) {
      // Its alpha at level 0, once per image and wrap modes.
      const int source = model_.textures[pbr.baseColorTexture.index].source;
      const auto key = std::make_tuple(source, a.texture.sampler.wrap_s, a.texture.sampler.wrap_t);
      auto slot = alpha_image_slot_.find(key);
      if (slot == alpha_image_slot_.end()) {
        const TextureImage::Level& level = images_[a.texture.image]->levels[0];
        AlphaImage im;
        im.width = static_cast<uint32_t>(level.width);
        im.height = static_cast<uint32_t>(level.height);
        im.wrap_s = a.texture.sampler.wrap_s;
        im.wrap_t = a.texture.sampler.wrap_t;
        im.alpha.resize(static_cast<size_t>(im.width) * im.height);
        for (size_t k = 0; k < im.alpha.size(); ++k) im.alpha[k] = level.rgba[4 * k + 3];
        alpha_images_.push_back(std::move(im));
        slot = alpha_image_slot_.emplace(key, static_cast<int>(alpha_images_.size() - 1)).first;
      }
      a.texture.image = slot->second;
    }
    mask = a;
  } else if (m.alphaMode != "OPAQUE") {
    fail(where + " has alphaMode '" + m.alphaMode + "' (glTF's are OPAQUE, MASK and BLEND)");
  }
  const auto put = alpha_materials_.emplace(material, mask).first;
  return put->second ? &*put->second : nullptr;
}

void Loader::add_alpha_masks(int mi, size_t pi, const std::string& where, Mesh& mesh, uint32_t base,
                             size_t vertex_count, size_t triangle_first) {
  const tinygltf::Primitive& prim = model_.meshes[mi].primitives[pi];
  const size_t triangles = mesh.triangle_count();
  mesh.alpha.reserve(triangles);
  const AlphaMaterial* mask = mask_of(prim.material);
  if (!mask) {
    mesh.alpha.resize(triangles);  // always kept
    return;
  }
  std::vector<glm::vec2> uv;
  if (mask->texture.image >= 0) {
    const std::string name = "TEXCOORD_" + std::to_string(mask->texture.texcoord);
    const auto t = prim.attributes.find(name);
    if (t == prim.attributes.end()) {
      warn(where + " has no " + name + ", which its material's alpha mask reads: it is sampled at (0, 0) there");
    } else {
      uv = read_vec2(t->second, where + ": " + name);
      if (uv.size() != vertex_count)
        fail(where + ": " + name + " has " + std::to_string(uv.size()) + " elements for " +
             std::to_string(vertex_count) + " positions");
    }
  }
  std::vector<glm::vec4> colors;
  const auto c = prim.attributes.find("COLOR_0");
  if (c != prim.attributes.end()) {
    colors = read_colors(c->second, where + ": COLOR_0");
    if (colors.size() != vertex_count)
      fail(where + ": COLOR_0 has " + std::to_string(colors.size()) + " elements for " + std::to_string(vertex_count) +
           " positions");
  }
  for (size_t t = triangle_first; t < triangles; ++t) {
    AlphaTriangle a;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = mesh.indices[3 * t + k] - base;
      const glm::dvec2 raw = uv.empty() ? glm::dvec2(0.0) : glm::dvec2(uv[v]);
      a.uv[k] = glm::vec2(glm::dvec2(mask->texture.uv_transform * glm::dvec3(raw, 1.0)));
      a.alpha[k] = static_cast<float>(mask->factor * (colors.empty() ? 1.0 : static_cast<double>(colors[v].w)));
    }
    a.cutoff = static_cast<float>(mask->cutoff);
    a.image = mask->texture.image;
    mesh.alpha.push_back(a);
  }
}

}  // namespace rayfold::core::gltf
