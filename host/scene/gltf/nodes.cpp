// Nodes: local and world transforms, GPU instancing, names, instances.
#include "scene/gltf/loader.h"

namespace rayfold::core::gltf {

std::vector<int> Loader::root_nodes() {
  for (const tinygltf::Scene& sc : model_.scenes) scene_.scene_names.push_back(sc.name);
  if (options_.scene >= 0 && static_cast<size_t>(options_.scene) >= model_.scenes.size())
    fail("scene " + std::to_string(options_.scene) + " does not exist (the file has " +
         std::to_string(model_.scenes.size()) + " scenes)");
  if (!model_.scenes.empty()) {
    const int s = options_.scene >= 0 ? options_.scene : model_.defaultScene >= 0 ? model_.defaultScene : 0;
    if (static_cast<size_t>(s) >= model_.scenes.size()) fail("the default scene index is out of range");
    scene_.scene_index = s;
    return model_.scenes[s].nodes;
  }
  // "scene" names a scene the file must have: --scene 0 on such a file is
  // an error, so its own default is too.
  if (model_.defaultScene >= 0)
    fail("\"scene\" is " + std::to_string(model_.defaultScene) + " but the file has no scenes");
  // No scene: every node that is nobody's child is a root.
  std::vector<char> is_child(model_.nodes.size(), 0);
  for (const tinygltf::Node& n : model_.nodes)
    for (int c : n.children)
      if (c >= 0 && static_cast<size_t>(c) < model_.nodes.size()) is_child[c] = 1;
  std::vector<int> roots;
  for (size_t i = 0; i < model_.nodes.size(); ++i)
    if (!is_child[i]) roots.push_back(static_cast<int>(i));
  return roots;
}

Xform Loader::local_transform(int ni) {
  const tinygltf::Node& n = model_.nodes[ni];
  const std::string where = "node " + std::to_string(ni);
  auto finite = [&](const std::vector<double>& v, const char* what) {
    for (double x : v)
      if (!std::isfinite(x)) fail(where + " has a non-finite " + what);
  };
  if (!n.matrix.empty()) {
    if (n.matrix.size() != 16) fail(where + " has a matrix with " + std::to_string(n.matrix.size()) + " values");
    finite(n.matrix, "matrix");
    Xform m = glm::make_mat4(n.matrix.data());
    if (m[0][3] != 0.0 || m[1][3] != 0.0 || m[2][3] != 0.0 || m[3][3] != 1.0)
      fail(where + " has a matrix that is not affine (its last row must be 0 0 0 1)");
    return m;
  }
  for (const auto* v : {&n.translation, &n.scale})
    if (!v->empty() && v->size() != 3) fail(where + " has a translation or scale without 3 values");
  if (!n.rotation.empty() && n.rotation.size() != 4) fail(where + " has a rotation without 4 values");
  finite(n.translation, "translation");
  finite(n.rotation, "rotation");
  finite(n.scale, "scale");
  return trs(n.translation.empty() ? nullptr : n.translation.data(), n.rotation.empty() ? nullptr : n.rotation.data(),
             n.scale.empty() ? nullptr : n.scale.data(), where);
}

Xform Loader::trs(const double* t, const double* r, const double* s, const std::string& where) {
  Xform m(1.0);
  if (t) m[3] = glm::dvec4(t[0], t[1], t[2], 1.0);
  if (r) {
    glm::dquat q(r[3], r[0], r[1], r[2]);
    const double len = glm::length(q);
    if (!(len > 0.0)) fail(where + " has a zero rotation quaternion");
    if (std::fabs(len - 1.0) > 1e-3) warn(where + " has a rotation quaternion that is not unit length; normalised");
    m = m * Xform(glm::mat4_cast(q / len));
  }
  if (s) m = glm::scale(m, glm::dvec3(s[0], s[1], s[2]));
  return m;
}

std::vector<Xform> Loader::gpu_instances(int ni) {
  const auto ext = model_.nodes[ni].extensions.find("EXT_mesh_gpu_instancing");
  if (ext == model_.nodes[ni].extensions.end()) return {};
  const std::string where = "node " + std::to_string(ni) + " (EXT_mesh_gpu_instancing)";
  if (!ext->second.IsObject() || !ext->second.Has("attributes") || !ext->second.Get("attributes").IsObject())
    fail(where + " has none of TRANSLATION, ROTATION and SCALE");
  const tinygltf::Value& attrs = ext->second.Get("attributes");
  std::vector<double> parts[3];
  const char* names[3] = {"TRANSLATION", "ROTATION", "SCALE"};
  const int components[3] = {3, 4, 3};
  size_t count = 0;
  bool any = false;
  for (int k = 0; k < 3; ++k) {
    if (!attrs.Has(names[k])) continue;
    if (!attrs.Get(names[k]).IsInt()) fail(where + ": " + names[k] + " must be an accessor index");
    const int ai = attrs.Get(names[k]).GetNumberAsInt();
    const std::string what = where + " " + names[k];
    if (ai >= 0 && static_cast<size_t>(ai) < model_.accessors.size()) {
      const tinygltf::Accessor& a = model_.accessors[ai];
      if (a.type != (k == 1 ? TINYGLTF_TYPE_VEC4 : TINYGLTF_TYPE_VEC3))
        fail(what + " must be " + (k == 1 ? "VEC4" : "VEC3"));
      const bool quantized_rotation =
          k == 1 && a.normalized &&
          (a.componentType == TINYGLTF_COMPONENT_TYPE_BYTE || a.componentType == TINYGLTF_COMPONENT_TYPE_SHORT);
      if (a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT && !quantized_rotation)
        fail(what + " must be FLOAT" + (k == 1 ? " or normalized byte or short" : ""));
    }
    parts[k] = read_elements(ai, what, components[k], false);
    for (double v : parts[k])
      if (!std::isfinite(v)) fail(what + " holds a non-finite value");
    const size_t n = parts[k].size() / components[k];
    if (any && n != count)
      fail(where + ": its attributes hold different numbers of instances (" + std::to_string(count) + " and " +
           std::to_string(n) + ")");
    count = n;
    any = true;
  }
  if (!any) fail(where + " has none of TRANSLATION, ROTATION and SCALE");
  std::vector<Xform> out(count);
  for (size_t i = 0; i < count; ++i)
    out[i] = trs(parts[0].empty() ? nullptr : &parts[0][3 * i], parts[1].empty() ? nullptr : &parts[1][4 * i],
                 parts[2].empty() ? nullptr : &parts[2][3 * i], where + " instance " + std::to_string(i));
  return out;
}

std::string Loader::node_name(int ni) const {
  const std::string& name = model_.nodes[ni].name;
  return name.empty() ? "node " + std::to_string(ni) : name;
}

void Loader::add_instance(int ni, const Xform& world_from_node) {
  const int mi = model_.nodes[ni].mesh;
  if (static_cast<size_t>(mi) >= model_.meshes.size())
    fail("node " + std::to_string(ni) + " refers to mesh " + std::to_string(mi) + ", which does not exist");
  // Morph weights: the node's override the mesh's; each set of weights is
  // a mesh of its own, and so is each skin a mesh is bound with.
  const std::vector<double>& weights =
      model_.nodes[ni].weights.empty() ? model_.meshes[mi].weights : model_.nodes[ni].weights;
  const int skin = model_.nodes[ni].skin;
  if (skin >= 0 && static_cast<size_t>(skin) >= model_.skins.size())
    fail("node " + std::to_string(ni) + " refers to skin " + std::to_string(skin) + ", which does not exist");
  const MeshKey key{mi, weights, skin};
  auto found = mesh_slot_.find(key);
  if (found == mesh_slot_.end()) found = mesh_slot_.emplace(key, mesh_for(mi, weights, skin)).first;
  const std::vector<Xform> gpu = gpu_instances(ni);
  if (found->second < 0) return;  // a mesh without triangles
  // A skinned mesh's vertices are placed by its joints, in world space;
  // the node's own transform does not apply (glTF 2.0, 3.7.3.3).
  const Xform world_from_object = skin >= 0 ? Xform(1.0) : world_from_node;
  if (linear_determinant(world_from_object) == 0.0)
    warn("node " + std::to_string(ni) + " has a zero scale; it is hidden");
  Instance inst;
  inst.mesh = static_cast<uint32_t>(found->second);
  inst.world_from_object = world_from_object;
  inst.name = node_name(ni);
  inst.node = ni;
  if (gpu.empty()) {
    scene_.instances.push_back(std::move(inst));
    return;
  }
  // One scene instance per GPU instance, consecutive ids, named
  // "<node>[i]".
  for (size_t i = 0; i < gpu.size(); ++i) {
    Instance g = inst;
    g.world_from_object = world_from_object * gpu[i];
    g.name = inst.name + "[" + std::to_string(i) + "]";
    if (linear_determinant(g.world_from_object) == 0.0)
      warn("node " + std::to_string(ni) + " GPU instance " + std::to_string(i) + " has a zero scale; it is hidden");
    scene_.instances.push_back(std::move(g));
  }
}

Xform Loader::node_world(int ni) {
  if (parent_.empty()) {
    parent_.assign(model_.nodes.size(), -1);
    for (size_t p = 0; p < model_.nodes.size(); ++p)
      for (int c : model_.nodes[p].children)
        if (c >= 0 && static_cast<size_t>(c) < model_.nodes.size()) parent_[c] = static_cast<int>(p);
    world_.resize(model_.nodes.size());
    world_known_.assign(model_.nodes.size(), 0);
  }
  std::vector<int> chain;
  for (int n = ni; n >= 0 && !world_known_[n]; n = parent_[n]) {
    if (chain.size() > model_.nodes.size()) fail("node " + std::to_string(ni) + " has a cycle among its ancestors");
    chain.push_back(n);
  }
  for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
    const int n = *it;
    world_[n] = (parent_[n] >= 0 ? world_[parent_[n]] : Xform(1.0)) * local_transform(n);
    world_known_[n] = 1;
  }
  return world_[ni];
}

}  // namespace rayfold::core::gltf
