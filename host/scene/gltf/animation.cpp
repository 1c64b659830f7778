// Animation: samplers at a time, node poses, morph targets and skins.
#include "scene/gltf/loader.h"

namespace rayfold::core::gltf {

double Loader::animation_end() const {
  double end = NAN;
  for (size_t ai = 0; ai < model_.animations.size(); ++ai)
    for (const tinygltf::AnimationChannel& ch : model_.animations[ai].channels) {
      if (ch.target_node < 0 || ch.sampler < 0 ||
          static_cast<size_t>(ch.sampler) >= model_.animations[ai].samplers.size())
        continue;
      const std::vector<double> keys = read_elements(model_.animations[ai].samplers[ch.sampler].input,
                                                     "animation " + std::to_string(ai) + " input", 1, false);
      if (!keys.empty()) end = std::isnan(end) ? keys.back() : std::max(end, keys.back());
    }
  return end;
}

void Loader::apply_morph_targets(int mi, size_t pi, const std::vector<double>& weights, const std::string& where,
                                 std::vector<glm::vec3>& values, const char* attribute) const {
  const tinygltf::Primitive& prim = model_.meshes[mi].primitives[pi];
  if (prim.targets.empty()) return;
  if (!weights.empty() && weights.size() != prim.targets.size())
    fail(where + " has " + std::to_string(prim.targets.size()) + " morph targets but " +
         std::to_string(weights.size()) + " weights");
  std::vector<glm::dvec3> sum(values.begin(), values.end());
  bool moved = false;
  const std::string name = attribute;
  for (size_t t = 0; t < prim.targets.size(); ++t) {
    const double w = weights.empty() ? 0.0 : weights[t];
    const auto p = prim.targets[t].find(name);
    if (w == 0.0 || p == prim.targets[t].end()) continue;
    const std::vector<glm::vec3> d = read_vec3(p->second, where + ": morph target " + std::to_string(t) + " " + name);
    if (d.size() != values.size())
      fail(where + ": morph target " + std::to_string(t) + " has " + std::to_string(d.size()) + " " + name +
           " values for " + std::to_string(values.size()) + " vertices");
    for (size_t i = 0; i < d.size(); ++i) sum[i] += w * glm::dvec3(d[i]);
    moved = true;
  }
  if (moved)
    for (size_t i = 0; i < values.size(); ++i) values[i] = glm::vec3(sum[i]);
}

void Loader::pose_at(double time) {
  if (!std::isfinite(time)) fail("the animation time must be finite");
  for (size_t ai = 0; ai < model_.animations.size(); ++ai) {
    const tinygltf::Animation& anim = model_.animations[ai];
    for (size_t ci = 0; ci < anim.channels.size(); ++ci) {
      const tinygltf::AnimationChannel& ch = anim.channels[ci];
      const std::string where = "animation " + std::to_string(ai) + " channel " + std::to_string(ci);
      if (ch.target_node < 0) continue;  // a channel of an extension's object
      if (static_cast<size_t>(ch.target_node) >= model_.nodes.size())
        fail(where + " targets node " + std::to_string(ch.target_node) + ", which does not exist");
      if (ch.sampler < 0 || static_cast<size_t>(ch.sampler) >= anim.samplers.size())
        fail(where + " refers to sampler " + std::to_string(ch.sampler) + ", which does not exist");
      tinygltf::Node& node = model_.nodes[ch.target_node];
      const int n = ch.target_path == "translation" || ch.target_path == "scale" ? 3
                    : ch.target_path == "rotation"                               ? 4
                    : ch.target_path == "weights" ? static_cast<int>(weight_count(ch.target_node))
                                                  : -1;
      if (n < 0) fail(where + " animates '" + ch.target_path + "', which is not a node property glTF defines");
      if (n == 0) fail(where + " animates the weights of a node whose mesh has no morph targets");
      if (ch.target_path != "weights" && !node.matrix.empty())
        fail(where + " animates node " + std::to_string(ch.target_node) + ", which has a matrix (glTF 2.0, 3.5.3)");
      const std::vector<double> v = sample(anim.samplers[ch.sampler], n, ch.target_path == "rotation", time, where);
      if (ch.target_path == "translation") node.translation = v;
      if (ch.target_path == "rotation") node.rotation = v;
      if (ch.target_path == "scale") node.scale = v;
      if (ch.target_path == "weights") node.weights = v;
    }
  }
}

size_t Loader::weight_count(int ni) const {
  const int mi = model_.nodes[ni].mesh;
  if (mi < 0 || static_cast<size_t>(mi) >= model_.meshes.size() || model_.meshes[mi].primitives.empty()) return 0;
  return model_.meshes[mi].primitives[0].targets.size();
}

std::vector<double> Loader::sample(const tinygltf::AnimationSampler& s, int n, bool rotation, double time,
                                   const std::string& where) const {
  const bool cubic = s.interpolation == "CUBICSPLINE";
  if (!cubic && s.interpolation != "LINEAR" && s.interpolation != "STEP")
    fail(where + " has the unknown interpolation '" + s.interpolation + "'");
  const std::vector<double> keys = read_elements(s.input, where + " input", 1, false);
  if (keys.empty()) fail(where + " has no keyframes");
  for (size_t k = 0; k < keys.size(); ++k)
    if (!std::isfinite(keys[k]) || (k > 0 && !(keys[k] > keys[k - 1])))
      fail(where + ": keyframe times must be finite and strictly increasing (key " + std::to_string(k) + ")");
  const size_t per = static_cast<size_t>(n) * (cubic ? 3 : 1);
  std::vector<double> out = read_elements(s.output, where + " output", components(s.output, where), false);
  if (out.size() != per * keys.size())
    fail(where + " has " + std::to_string(out.size()) + " output values for " + std::to_string(keys.size()) +
         " keyframes of " + std::to_string(per));
  for (double x : out)
    if (!std::isfinite(x)) fail(where + " has a non-finite output value");
  auto value = [&](size_t k, int part) {  // part: 0 in-tangent, 1 value, 2 out-tangent (cubic)
    const size_t base = k * per + (cubic ? static_cast<size_t>(part) * n : 0);
    return std::vector<double>(out.begin() + base, out.begin() + base + n);
  };
  if (time <= keys.front()) return value(0, 1);
  if (time >= keys.back()) return value(keys.size() - 1, 1);
  const size_t k = static_cast<size_t>(std::upper_bound(keys.begin(), keys.end(), time) - keys.begin()) - 1;
  const double dt = keys[k + 1] - keys[k], u = (time - keys[k]) / dt;
  std::vector<double> a = value(k, 1), b = value(k + 1, 1), r(n);
  if (s.interpolation == "STEP") return a;
  if (cubic) {
    const std::vector<double> out_tangent = value(k, 2), in_tangent = value(k + 1, 0);
    const double u2 = u * u, u3 = u2 * u;
    for (int c = 0; c < n; ++c)
      r[c] = (2 * u3 - 3 * u2 + 1) * a[c] + (u3 - 2 * u2 + u) * dt * out_tangent[c] + (-2 * u3 + 3 * u2) * b[c] +
             (u3 - u2) * dt * in_tangent[c];
  } else if (rotation) {
    glm::dquat qa(a[3], a[0], a[1], a[2]), qb(b[3], b[0], b[1], b[2]);
    const glm::dquat q = glm::slerp(glm::normalize(qa), glm::normalize(qb), u);
    r = {q.x, q.y, q.z, q.w};
  } else {
    for (int c = 0; c < n; ++c) r[c] = a[c] + u * (b[c] - a[c]);
  }
  if (rotation) {
    const double len = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
    if (!(len > 0.0)) fail(where + " interpolates to a zero rotation");
    for (double& x : r) x /= len;
  }
  return r;
}

std::vector<Xform> Loader::joint_matrices(int si) {
  const tinygltf::Skin& sk = model_.skins[si];
  const std::string where = "skin " + std::to_string(si);
  if (sk.joints.empty()) fail(where + " has no joints");
  std::vector<double> ibm;
  if (sk.inverseBindMatrices >= 0) {
    if (static_cast<size_t>(sk.inverseBindMatrices) < model_.accessors.size()) {
      const tinygltf::Accessor& a = model_.accessors[sk.inverseBindMatrices];
      if (a.type != TINYGLTF_TYPE_MAT4 || a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
        fail(where + ": inverseBindMatrices must be MAT4 of FLOAT");
    }
    ibm = read_elements(sk.inverseBindMatrices, where + " inverseBindMatrices", 16, false);
    if (ibm.size() != 16 * sk.joints.size())
      fail(where + " has " + std::to_string(ibm.size() / 16) + " inverse bind matrices for " +
           std::to_string(sk.joints.size()) + " joints");
  }
  std::vector<Xform> out;
  for (size_t j = 0; j < sk.joints.size(); ++j) {
    const int jn = sk.joints[j];
    if (jn < 0 || static_cast<size_t>(jn) >= model_.nodes.size())
      fail(where + ": joint " + std::to_string(j) + " is node " + std::to_string(jn) + ", which does not exist");
    Xform inverse_bind(1.0);
    if (!ibm.empty()) {
      for (int k = 0; k < 16; ++k)
        if (!std::isfinite(ibm[16 * j + k]))
          fail(where + ": inverse bind matrix " + std::to_string(j) + " is not finite");
      inverse_bind = glm::make_mat4(&ibm[16 * j]);
    }
    out.push_back(node_world(jn) * inverse_bind);
  }
  return out;
}

void Loader::apply_skin(const tinygltf::Primitive& prim, const std::vector<Xform>& joints, const std::string& where,
                        std::vector<glm::vec3>& positions, std::vector<glm::vec3>* normals,
                        std::vector<glm::vec4>* tangents) const {
  std::vector<glm::dvec3> sum(positions.size(), glm::dvec3(0.0));
  std::vector<glm::dvec3> normal_sum(normals ? normals->size() : 0, glm::dvec3(0.0));
  std::vector<glm::dvec3> tangent_sum(tangents ? tangents->size() : 0, glm::dvec3(0.0));
  std::vector<glm::dmat3> normal_from_object;
  if (normals)
    for (const Xform& j : joints) normal_from_object.push_back(glm::transpose(glm::inverse(glm::dmat3(j))));
  std::vector<double> total(positions.size(), 0.0);
  int sets = 0;
  for (int set = 0;; ++set) {
    const auto j = prim.attributes.find("JOINTS_" + std::to_string(set));
    const auto w = prim.attributes.find("WEIGHTS_" + std::to_string(set));
    if (j == prim.attributes.end() && w == prim.attributes.end()) break;
    if (j == prim.attributes.end() || w == prim.attributes.end())
      fail(where + ": JOINTS_" + std::to_string(set) + " and WEIGHTS_" + std::to_string(set) + " come in pairs");
    const std::vector<double> ji = read_elements(j->second, where + ": JOINTS_" + std::to_string(set), 4, false);
    const std::vector<double> wi = read_elements(w->second, where + ": WEIGHTS_" + std::to_string(set), 4, false);
    if (ji.size() != 4 * positions.size() || wi.size() != 4 * positions.size())
      fail(where + ": JOINTS_" + std::to_string(set) + " or WEIGHTS_" + std::to_string(set) +
           " does not have one element per vertex");
    for (size_t v = 0; v < positions.size(); ++v)
      for (int k = 0; k < 4; ++k) {
        const double weight = wi[4 * v + k];
        if (weight == 0.0) continue;
        if (!(weight >= 0.0) || !std::isfinite(weight))
          fail(where + ": vertex " + std::to_string(v) + " has a weight that is not a finite non-negative number");
        const double joint = ji[4 * v + k];
        if (joint < 0.0 || joint >= static_cast<double>(joints.size()) || joint != std::floor(joint))
          fail(where + ": vertex " + std::to_string(v) + " refers to joint " +
               std::to_string(static_cast<long long>(joint)) + " of " + std::to_string(joints.size()));
        sum[v] += weight * glm::dvec3(joints[static_cast<size_t>(joint)] * glm::dvec4(glm::dvec3(positions[v]), 1.0));
        if (normals)
          normal_sum[v] += weight * (normal_from_object[static_cast<size_t>(joint)] * glm::dvec3((*normals)[v]));
        if (tangents)
          tangent_sum[v] +=
              weight * (glm::dmat3(joints[static_cast<size_t>(joint)]) * glm::dvec3(glm::vec3((*tangents)[v])));
        total[v] += weight;
      }
    ++sets;
  }
  if (sets == 0) fail(where + " is bound to a skin but has no JOINTS_0 and WEIGHTS_0");
  for (size_t v = 0; v < positions.size(); ++v) {
    if (!(total[v] > 0.0)) fail(where + ": vertex " + std::to_string(v) + " has no joint weight");
    // Weights should sum to 1; normalising keeps a file that rounds them
    // (as 8-bit weights do) from shrinking the mesh.
    positions[v] = glm::vec3(sum[v] / total[v]);
    if (normals) (*normals)[v] = glm::vec3(normal_sum[v] / total[v]);
    if (tangents) (*tangents)[v] = glm::vec4(glm::vec3(tangent_sum[v] / total[v]), (*tangents)[v].w);
  }
}

}  // namespace rayfold::core::gltf
