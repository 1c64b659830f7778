// Vertex attributes and materials, read only when a render's channels ask
// for them (LoadOptions::attributes, scene/attributes.h).
#include "scene/gltf/loader.h"

namespace rayfold::core::gltf {

std::vector<glm::vec2> Loader::read_vec2(int ai, const std::string& what) const {
  if (ai < 0 || static_cast<size_t>(ai) >= model_.accessors.size())
    fail(what + " accessor " + std::to_string(ai) + " does not exist");
  const tinygltf::Accessor& a = model_.accessors[ai];
  if (a.type != TINYGLTF_TYPE_VEC2) fail(what + " accessor " + std::to_string(ai) + " must be VEC2");
  const bool plain = a.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT ||
                     ((a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                       a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) &&
                      a.normalized);
  if (!plain && !uses_extension("KHR_mesh_quantization"))
    fail(what + " accessor " + std::to_string(ai) +
         " must be FLOAT or normalized unsigned byte or short (other integers need KHR_mesh_quantization)");
  if (a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
    fail(what + " accessor " + std::to_string(ai) + " must be FLOAT or (normalized) byte or short");
  const std::vector<double> e = read_elements(ai, what, 2, false);
  std::vector<glm::vec2> out(e.size() / 2);
  for (size_t i = 0; i < out.size(); ++i) {
    out[i] = glm::vec2(static_cast<float>(e[2 * i]), static_cast<float>(e[2 * i + 1]));
    if (!std::isfinite(out[i].x) || !std::isfinite(out[i].y)) fail(what + " " + std::to_string(i) + " is not finite");
  }
  return out;
}

std::vector<glm::vec4> Loader::read_colors(int ai, const std::string& what) const {
  if (ai < 0 || static_cast<size_t>(ai) >= model_.accessors.size())
    fail(what + " accessor " + std::to_string(ai) + " does not exist");
  const tinygltf::Accessor& a = model_.accessors[ai];
  if (a.type != TINYGLTF_TYPE_VEC3 && a.type != TINYGLTF_TYPE_VEC4)
    fail(what + " accessor " + std::to_string(ai) + " must be VEC3 or VEC4");
  const bool plain = a.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT ||
                     ((a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                       a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT) &&
                      a.normalized);
  if (!plain) fail(what + " accessor " + std::to_string(ai) + " must be FLOAT or normalized unsigned byte or short");
  const int n = a.type == TINYGLTF_TYPE_VEC3 ? 3 : 4;
  const std::vector<double> e = read_elements(ai, what, n, false);
  std::vector<glm::vec4> out(e.size() / n, glm::vec4(1.0f));
  for (size_t i = 0; i < out.size(); ++i)
    for (int k = 0; k < n; ++k) {
      out[i][k] = static_cast<float>(e[n * i + k]);
      if (!std::isfinite(out[i][k])) fail(what + " " + std::to_string(i) + " is not finite");
    }
  return out;
}

void Loader::read_normals(int mi, size_t pi, const std::string& where, size_t vertex_count,
                          const std::vector<double>& weights, MeshAttributes& out) {
  const tinygltf::Primitive& prim = model_.meshes[mi].primitives[pi];
  const auto n = prim.attributes.find("NORMAL");
  if (n == prim.attributes.end()) {
    out.normals.resize(out.normals.size() + vertex_count, glm::vec3(0.0f));
    out.missing |= kAttributeNormal;
    return;
  }
  std::vector<glm::vec3> normals = read_vec3(n->second, where + ": NORMAL");
  if (normals.size() != vertex_count)
    fail(where + ": NORMAL has " + std::to_string(normals.size()) + " elements for " + std::to_string(vertex_count) +
         " positions");
  apply_morph_targets(mi, pi, weights, where, normals, "NORMAL");
  out.present |= kAttributeNormal;
  out.normals.insert(out.normals.end(), normals.begin(), normals.end());
}

void Loader::read_attributes(int mi, size_t pi, const std::string& where, size_t vertex_count, size_t triangles,
                             MeshAttributes& out) {
  const tinygltf::Primitive& prim = model_.meshes[mi].primitives[pi];
  for (int set = 0; set < 2; ++set) {
    if (!(options_.attributes & (set == 0 ? kAttributeTexcoord0 : kAttributeTexcoord1))) continue;
    const std::string name = "TEXCOORD_" + std::to_string(set);
    std::vector<glm::vec2>& texcoords = out.texcoords[set];
    const auto t = prim.attributes.find(name);
    if (t == prim.attributes.end()) {
      texcoords.resize(texcoords.size() + vertex_count, glm::vec2(0.0f));
      out.missing |= set == 0 ? kAttributeTexcoord0 : kAttributeTexcoord1;
      continue;
    }
    const std::vector<glm::vec2> read = read_vec2(t->second, where + ": " + name);
    if (read.size() != vertex_count)
      fail(where + ": " + name + " has " + std::to_string(read.size()) + " elements for " +
           std::to_string(vertex_count) + " positions");
    texcoords.insert(texcoords.end(), read.begin(), read.end());
    out.present |= set == 0 ? kAttributeTexcoord0 : kAttributeTexcoord1;
  }
  if (options_.attributes & kAttributeColor0) {
    const auto c = prim.attributes.find("COLOR_0");
    if (c == prim.attributes.end()) {
      out.colors.resize(out.colors.size() + vertex_count, glm::vec4(1.0f));
      out.missing |= kAttributeColor0;
    } else {
      const std::vector<glm::vec4> read = read_colors(c->second, where + ": COLOR_0");
      if (read.size() != vertex_count)
        fail(where + ": COLOR_0 has " + std::to_string(read.size()) + " elements for " + std::to_string(vertex_count) +
             " positions");
      out.colors.insert(out.colors.end(), read.begin(), read.end());
      out.present |= kAttributeColor0;
    }
  }
  if (options_.attributes & kAttributeMaterial) {
    if (prim.material >= 0 && static_cast<size_t>(prim.material) >= model_.materials.size())
      fail(where + " refers to material " + std::to_string(prim.material) + " of " +
           std::to_string(model_.materials.size()));
    out.materials.resize(out.materials.size() + triangles,
                         prim.material < 0 ? kDefaultMaterial : static_cast<uint32_t>(prim.material));
  }
}

}  // namespace rayfold::core::gltf
