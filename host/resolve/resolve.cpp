#include "resolve/resolve.h"

#include <cmath>

#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>

#include "device_layout.h"
#include "util/errors.h"
#include "util/parallel.h"

namespace rayfold::core {
namespace {

// Per instance, what its pixels' resolve needs of its transform.
struct InstanceXforms {
  Xform world_from_object;
  glm::dmat3 normal_from_object;  // the inverse transpose of the linear part
};

template <class V>
V interpolate(const V& a0, const V& a1, const V& a2, double b0, double u, double v) {
  return b0 * a0 + u * a1 + v * a2;
}

bool zero(const glm::vec3& n) { return n.x == 0.0f && n.y == 0.0f && n.z == 0.0f; }

}  // namespace

unsigned attributes_read(const ResolvedPlanes& out) {
  return (out.shading_normal ? kAttributeNormal : 0u) | (out.texcoord[0] ? kAttributeTexcoord0 : 0u) |
         (out.texcoord[1] ? kAttributeTexcoord1 : 0u) | (out.material ? kAttributeMaterial : 0u);
}

void resolve(const Scene& scene, const HitPlanes& in, const ResolvedPlanes& out, unsigned threads) {
  RF_CHECK(in.instance && in.primitive && in.barycentrics, "the resolve needs the hits' ids and barycentrics");
  RF_CHECK(!out.shading_normal || in.normal, "shading normals need the geometric normal as their stand-in");
  std::vector<InstanceXforms> xforms(scene.instances.size());
  for (size_t i = 0; i < xforms.size(); ++i) {
    const Xform& m = scene.instances[i].world_from_object;
    xforms[i] = {m, glm::transpose(glm::inverse(glm::dmat3(m)))};
  }
  parallel_for(in.pixels, threads, size_t{1} << 13, [&](size_t begin, size_t end) {
    for (size_t p = begin; p < end; ++p) {
      const uint32_t inst = in.instance[p];
      if (inst == RF_INVALID) {
        auto clear = [&](float* plane, int n) {
          if (plane)
            for (int k = 0; k < n; ++k) plane[n * p + k] = 0.0f;
        };
        clear(out.position, 3);
        clear(out.object_position, 3);
        clear(out.shading_normal, 3);
        clear(out.texcoord[0], 2);
        clear(out.texcoord[1], 2);
        if (out.material) out.material[p] = RF_INVALID;
        continue;
      }
      RF_CHECK_LT(inst, scene.instances.size(), "a hit on an instance the scene does not have");
      const Mesh& mesh = scene.meshes[scene.instances[inst].mesh];
      const uint32_t tri = in.primitive[p];
      RF_CHECK_LT(tri, mesh.triangle_count(), "a hit on a triangle its mesh does not have");
      const uint32_t i0 = mesh.indices[3 * tri], i1 = mesh.indices[3 * tri + 1], i2 = mesh.indices[3 * tri + 2];
      const double u = in.barycentrics[2 * p], v = in.barycentrics[2 * p + 1];
      const double b0 = (1.0 - u) - v;
      const InstanceXforms& x = xforms[inst];
      if (out.position || out.object_position) {
        const glm::dvec3 o = interpolate(glm::dvec3(mesh.positions[i0]), glm::dvec3(mesh.positions[i1]),
                                         glm::dvec3(mesh.positions[i2]), b0, u, v);
        if (out.object_position)
          for (int k = 0; k < 3; ++k) out.object_position[3 * p + k] = static_cast<float>(o[k]);
        if (out.position) {
          const glm::dvec3 w = glm::dvec3(x.world_from_object * glm::dvec4(o, 1.0));
          for (int k = 0; k < 3; ++k) out.position[3 * p + k] = static_cast<float>(w[k]);
        }
      }
      if (out.shading_normal) {
        const std::vector<glm::vec3>& n = mesh.attributes.normals;
        bool flat = n.empty() || zero(n[i0]) || zero(n[i1]) || zero(n[i2]);
        glm::dvec3 w(0.0);
        if (!flat) {
          w = x.normal_from_object * interpolate(glm::dvec3(n[i0]), glm::dvec3(n[i1]), glm::dvec3(n[i2]), b0, u, v);
          const double length = std::sqrt(w.x * w.x + w.y * w.y + w.z * w.z);
          flat = !(length > 0.0) || !std::isfinite(length);
          w /= length;
        }
        for (int k = 0; k < 3; ++k)
          out.shading_normal[3 * p + k] = flat ? in.normal[3 * p + k] : static_cast<float>(w[k]);
      }
      for (int set = 0; set < 2; ++set) {
        if (!out.texcoord[set]) continue;
        const std::vector<glm::vec2>& t = mesh.attributes.texcoords[set];
        glm::dvec2 tc(0.0);
        if (!t.empty()) tc = interpolate(glm::dvec2(t[i0]), glm::dvec2(t[i1]), glm::dvec2(t[i2]), b0, u, v);
        out.texcoord[set][2 * p] = static_cast<float>(tc.x);
        out.texcoord[set][2 * p + 1] = static_cast<float>(tc.y);
      }
      if (out.material)
        out.material[p] = mesh.attributes.materials.empty() ? kDefaultMaterial : mesh.attributes.materials[tri];
    }
  });
}

std::vector<std::string> missing_attribute_warnings(const Scene& scene, unsigned attributes) {
  struct Stand {
    unsigned bit;
    const char* attribute;
    const char* instead;
  };
  static const Stand kStands[] = {
      {kAttributeNormal, "NORMAL", "shading_normal is the geometric normal there"},
      {kAttributeTexcoord0, "TEXCOORD_0", "texcoord is (0, 0) there"},
      {kAttributeTexcoord1, "TEXCOORD_1", "texcoord1 is (0, 0) there"},
  };
  std::vector<std::string> out;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const Mesh& mesh = scene.meshes[m];
    const std::string name = "mesh " + std::to_string(m) + (mesh.name.empty() ? "" : " ('" + mesh.name + "')");
    for (const Stand& s : kStands) {
      if (!(attributes & s.bit)) continue;
      const bool none = !(mesh.attributes.loaded & s.bit) || !(mesh.attributes.present & s.bit);
      if (!none && !(mesh.attributes.missing & s.bit)) continue;
      out.push_back(name + (none ? " has no " : " has primitives without ") + s.attribute + ": " + s.instead +
                    (none && mesh.attributes.loaded == 0 ? " (a mesh built in memory or read from a scene file "
                                                           "keeps positions only)"
                                                         : ""));
    }
  }
  return out;
}

}  // namespace rayfold::core
