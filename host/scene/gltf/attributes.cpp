// Vertex attributes and materials, read only when a render's channels ask
// for them (LoadOptions::attributes, scene/attributes.h).
#include "scene/gltf/loader.h"
#include "scene/tangents.h"

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

std::vector<glm::vec4> Loader::read_tangents(int mi, size_t pi, const std::string& where, size_t vertex_count,
                                             const std::vector<double>& weights) const {
  const tinygltf::Primitive& prim = model_.meshes[mi].primitives[pi];
  const int ai = prim.attributes.at("TANGENT");
  const std::string what = where + ": TANGENT";
  if (ai < 0 || static_cast<size_t>(ai) >= model_.accessors.size())
    fail(what + " accessor " + std::to_string(ai) + " does not exist");
  const tinygltf::Accessor& a = model_.accessors[ai];
  if (a.type != TINYGLTF_TYPE_VEC4) fail(what + " accessor " + std::to_string(ai) + " must be VEC4");
  const bool quantized =
      (a.componentType == TINYGLTF_COMPONENT_TYPE_BYTE || a.componentType == TINYGLTF_COMPONENT_TYPE_SHORT) &&
      a.normalized;
  if (a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT && !(quantized && uses_extension("KHR_mesh_quantization")))
    fail(what + " accessor " + std::to_string(ai) +
         " must be FLOAT (normalized byte or short only with KHR_mesh_quantization)");
  const std::vector<double> e = read_elements(ai, what, 4, false);
  if (e.size() != 4 * vertex_count)
    fail(what + " has " + std::to_string(e.size() / 4) + " elements for " + std::to_string(vertex_count) +
         " positions");
  std::vector<glm::vec3> xyz(vertex_count);
  std::vector<glm::vec4> out(vertex_count);
  for (size_t i = 0; i < vertex_count; ++i) {
    xyz[i] =
        glm::vec3(static_cast<float>(e[4 * i]), static_cast<float>(e[4 * i + 1]), static_cast<float>(e[4 * i + 2]));
    const double w = e[4 * i + 3];
    if (!std::isfinite(xyz[i].x) || !std::isfinite(xyz[i].y) || !std::isfinite(xyz[i].z) || !std::isfinite(w))
      fail(what + " " + std::to_string(i) + " is not finite");
    out[i].w = w < 0.0 ? -1.0f : 1.0f;  // glTF: -1 or +1
  }
  apply_morph_targets(mi, pi, weights, where, xyz, "TANGENT");
  for (size_t i = 0; i < vertex_count; ++i) out[i] = glm::vec4(xyz[i], out[i].w);
  return out;
}

int Loader::normal_texcoord_set(int material) const {
  if (material < 0 || static_cast<size_t>(material) >= model_.materials.size()) return 0;
  const tinygltf::NormalTextureInfo& info = model_.materials[material].normalTexture;
  int set = info.texCoord;
  const auto transform = info.extensions.find("KHR_texture_transform");
  if (transform != info.extensions.end() && transform->second.Has("texCoord") &&
      transform->second.Get("texCoord").IsInt())
    set = transform->second.Get("texCoord").Get<int>();
  return set;
}

void Loader::add_corner_tangents(int mi, size_t pi, const std::string& where, Mesh& mesh, uint32_t base,
                                 size_t vertex_count, size_t triangle_first, size_t normal_first,
                                 const std::vector<glm::vec4>& file_tangents) {
  const tinygltf::Primitive& prim = model_.meshes[mi].primitives[pi];
  MeshAttributes& out = mesh.attributes;
  const size_t first = 3 * triangle_first, corners = mesh.indices.size() - first;
  if (!file_tangents.empty()) {
    out.tangents.reserve(mesh.indices.size());
    for (size_t c = first; c < mesh.indices.size(); ++c) out.tangents.push_back(file_tangents[mesh.indices[c] - base]);
    out.present |= kAttributeTangent;
    return;
  }
  const std::string name = "TEXCOORD_" + std::to_string(normal_texcoord_set(prim.material));
  const auto t = prim.attributes.find(name);
  if (t == prim.attributes.end()) {
    out.tangents.resize(mesh.indices.size(), glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));
    out.missing |= kAttributeTangent;
    return;
  }
  const std::vector<glm::vec2> texcoords = read_vec2(t->second, where + ": " + name);
  if (texcoords.size() != vertex_count)
    fail(where + ": " + name + " has " + std::to_string(texcoords.size()) + " elements for " +
         std::to_string(vertex_count) + " positions");
  std::vector<uint32_t> local(mesh.indices.begin() + first, mesh.indices.end());
  for (uint32_t& i : local) i -= base;
  const bool normals = out.normals.size() >= normal_first + vertex_count;
  const std::vector<glm::vec4> made =
      mikktspace_tangents(mesh.positions.data() + base, normals ? out.normals.data() + normal_first : nullptr,
                          texcoords.data(), local.data(), corners / 3);
  out.tangents.insert(out.tangents.end(), made.begin(), made.end());
  out.present |= kAttributeTangent;
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
