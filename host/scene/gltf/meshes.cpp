// Meshes: glTF primitives to triangles, converted once per key.
#include "scene/gltf/loader.h"

namespace rayfold::core::gltf {

int Loader::mesh_for(int mi, const std::vector<double>& weights, int skin) {
  if (!cache_meshes_ || skin >= 0 || !weights.empty()) return convert_mesh(mi, weights, skin);
  const MeshKey key{mi, weights, skin};
  const auto cached = converted_.find(key);
  if (cached == converted_.end()) {
    const int slot = convert_mesh(mi, weights, skin);
    converted_.emplace(key, slot < 0 ? std::optional<Mesh>() : std::optional<Mesh>(scene_.meshes[slot]));
    return slot;
  }
  if (!cached->second) return -1;
  scene_.meshes.push_back(*cached->second);
  return static_cast<int>(scene_.meshes.size()) - 1;
}

int Loader::convert_mesh(int mi, const std::vector<double>& weights, int skin) {
  const std::vector<Xform> joints = skin >= 0 ? joint_matrices(skin) : std::vector<Xform>{};
  const tinygltf::Mesh& gm = model_.meshes[mi];
  Mesh mesh;
  mesh.name = gm.name;
  mesh.attributes.loaded = options_.attributes;
  // A mesh with a masked primitive gets a mask per triangle (the others' kept).
  bool masked = false;
  for (const tinygltf::Primitive& prim : gm.primitives) {
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    const bool triangles =
        mode == TINYGLTF_MODE_TRIANGLES || mode == TINYGLTF_MODE_TRIANGLE_STRIP || mode == TINYGLTF_MODE_TRIANGLE_FAN;
    masked |= triangles && mask_of(prim.material) != nullptr;
  }
  for (size_t pi = 0; pi < gm.primitives.size(); ++pi) {
    const tinygltf::Primitive& prim = gm.primitives[pi];
    const std::string where = "mesh " + std::to_string(mi) + " primitive " + std::to_string(pi);
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode == TINYGLTF_MODE_POINTS || mode == TINYGLTF_MODE_LINE || mode == TINYGLTF_MODE_LINE_LOOP ||
        mode == TINYGLTF_MODE_LINE_STRIP) {
      warn(where + " draws points or lines; skipped");
      continue;
    }
    if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN)
      fail(where + " has an unknown primitive mode " + std::to_string(mode));
    // Morph targets move POSITION, NORMAL and TANGENT here (glTF's SHOULD);
    // a target moving an attribute a channel reads is named, not ignored unsaid.
    std::set<std::string> unmorphed;
    for (const std::map<std::string, int>& target : prim.targets)
      for (const auto& [attribute, accessor] : target) {
        const unsigned bit = attribute == "TEXCOORD_0"   ? kAttributeTexcoord0
                             : attribute == "TEXCOORD_1" ? kAttributeTexcoord1
                             : attribute == "COLOR_0"    ? kAttributeColor0
                                                         : 0u;
        if (bit & options_.attributes) unmorphed.insert(attribute);
      }
    for (const std::string& attribute : unmorphed)
      warn(where + "'s morph targets move " + attribute +
           ", which rayfold does not morph: its values at rest are used");
    const auto pos = prim.attributes.find("POSITION");
    if (pos == prim.attributes.end()) fail(where + " has no POSITION attribute");
    const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
    std::vector<glm::vec3> positions = read_vec3(pos->second, where + ": POSITION");
    const size_t first_normal = mesh.attributes.normals.size();
    if (options_.attributes & kAttributeNormal) read_normals(mi, pi, where, positions.size(), weights, mesh.attributes);
    apply_morph_targets(mi, pi, weights, where, positions);
    // The file's tangents, morphed and skinned as its normals; none: made
    // below from the posed mesh (scene/tangents.h).
    std::vector<glm::vec4> tangents;
    if ((options_.attributes & kAttributeTangent) && prim.attributes.count("TANGENT"))
      tangents = read_tangents(mi, pi, where, positions.size(), weights);
    if (skin >= 0) {
      std::vector<glm::vec3> normals;
      const bool with_normals = (options_.attributes & kAttributeNormal) && prim.attributes.count("NORMAL");
      if (with_normals) normals.assign(mesh.attributes.normals.begin() + first_normal, mesh.attributes.normals.end());
      apply_skin(prim, joints, where, positions, with_normals ? &normals : nullptr,
                 tangents.empty() ? nullptr : &tangents);
      if (with_normals) std::copy(normals.begin(), normals.end(), mesh.attributes.normals.begin() + first_normal);
    }
    const uint32_t vertex_count = static_cast<uint32_t>(positions.size());
    // A mesh's first primitive is taken whole: a copy was 5 MB of fresh
    // pages on the dragon.
    if (mesh.positions.empty())
      mesh.positions = std::move(positions);
    else
      mesh.positions.insert(mesh.positions.end(), positions.begin(), positions.end());
    std::vector<uint32_t> seq;
    if (prim.indices >= 0) {
      read_indices(prim.indices, where, vertex_count, seq);
    } else {
      seq.resize(vertex_count);
      for (uint32_t i = 0; i < vertex_count; ++i) seq[i] = i;
    }
    size_t dropped = 0;
    const size_t seq_size = seq.size();
    const size_t triangles_before = mesh.triangle_count();
    append_triangles(mode, std::move(seq), base, mesh.indices, &dropped);
    read_attributes(mi, pi, where, vertex_count, mesh.triangle_count() - triangles_before, mesh.attributes);
    if (options_.attributes & kAttributeTangent)
      add_corner_tangents(mi, pi, where, mesh, base, vertex_count, triangles_before, first_normal, tangents);
    if (masked) add_alpha_masks(mi, pi, where, mesh, base, vertex_count, triangles_before);
    if (dropped)
      warn(where + " has " + std::to_string(seq_size) + " triangle vertices, not a multiple of 3; the last " +
           std::to_string(dropped) + " are ignored");
  }
  // An attribute no primitive of the mesh has is its stand-in everywhere:
  // kept as none (attributes.h), not a copy per vertex, so that white is
  // exactly white and the resolve sees a constant over each triangle.
  MeshAttributes& a = mesh.attributes;
  auto drop_unless_present = [&](auto& values, unsigned bit) {
    if (a.present & bit) return;
    values.clear();
    values.shrink_to_fit();
  };
  drop_unless_present(a.normals, kAttributeNormal);
  drop_unless_present(a.texcoords[0], kAttributeTexcoord0);
  drop_unless_present(a.texcoords[1], kAttributeTexcoord1);
  drop_unless_present(a.colors, kAttributeColor0);
  if (mesh.indices.empty()) {
    warn("mesh " + std::to_string(mi) + (gm.name.empty() ? "" : " (" + gm.name + ")") + " has no triangles");
    return -1;
  }
  scene_.meshes.push_back(std::move(mesh));
  return static_cast<int>(scene_.meshes.size()) - 1;
}

void Loader::append_triangles(int mode, std::vector<uint32_t>&& seq, uint32_t base, std::vector<uint32_t>& out,
                              size_t* dropped) {
  auto tri = [&](uint32_t a, uint32_t b, uint32_t c) {
    out.push_back(base + seq[a]);
    out.push_back(base + seq[b]);
    out.push_back(base + seq[c]);
  };
  const size_t n = seq.size();
  if (mode == TINYGLTF_MODE_TRIANGLES && out.empty() && base == 0) {
    // A mesh's first list of triangles is its indices as read.
    if (n % 3 != 0 && dropped) *dropped = n % 3;
    seq.resize(n - n % 3);
    out = std::move(seq);
    return;
  }
  // Grown once a primitive: a push_back at a time, the dragon's 2.6M
  // indices were copied into ever larger fresh arrays (20 MB of page
  // faults). At least doubled, so that a mesh of many primitives is not
  // copied once for each.
  const size_t triangles = mode == TINYGLTF_MODE_TRIANGLES ? n / 3 : (n >= 3 ? n - 2 : 0);
  const size_t needed = out.size() + 3 * triangles;
  if (needed > out.capacity()) out.reserve(std::max(needed, 2 * out.capacity()));
  if (mode == TINYGLTF_MODE_TRIANGLES) {
    for (size_t i = 0; i + 2 < n; i += 3) tri(i, i + 1, i + 2);
    if (n % 3 != 0 && dropped) *dropped = n % 3;
  } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
    // glTF 2.0 spec 3.7.2.1: triangle i is (i, i + 1 + i % 2, i + 2 - i % 2).
    for (size_t i = 0; i + 2 < n; ++i) tri(i, i + 1 + i % 2, i + 2 - i % 2);
  } else {
    // Fan: triangle i is (i + 1, i + 2, 0).
    for (size_t i = 0; i + 2 < n; ++i) tri(i + 1, i + 2, 0);
  }
}

}  // namespace rayfold::core::gltf
