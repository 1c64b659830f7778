#include "resolve/resolve.h"

#include <cmath>
#include <set>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/matrix.hpp>

#include "device_layout.h"
#include "resolve/texture_sampling.h"
#include "util/errors.h"
#include "util/parallel.h"

namespace rayfold::core {
namespace {

// Per instance, what its pixels' resolve needs of its transform.
struct InstanceXforms {
  Xform world_from_object;
  glm::dmat3 normal_from_object;  // the inverse transpose of the linear part
  double handedness;              // the linear part's determinant's sign (-1: it mirrors)
};

template <class V>
V interpolate(const V& a0, const V& a1, const V& a2, double b0, double u, double v) {
  return b0 * a0 + u * a1 + v * a2;
}

bool zero(const glm::vec3& n) { return n.x == 0.0f && n.y == 0.0f && n.z == 0.0f; }

// What a material channel reads of a hit's triangle: its corners in world
// space and the cone's footprint there.
struct Footprint {
  double world_area2;  // twice the triangle's world-space area
  double width;        // W / |cos theta| (resolve.h's RayCone)
};

Footprint footprint(const RayCone& cone, const glm::dvec3 w[3], const glm::dvec3& hit) {
  const glm::dvec3 n = glm::cross(w[1] - w[0], w[2] - w[0]);
  const double area2 = glm::length(n);
  glm::dvec3 dir = cone.forward;
  double width = cone.width;
  if (!cone.orthographic) {
    const double t = glm::length(hit - cone.eye);
    width = cone.spread * t;
    dir = (hit - cone.eye) / t;
  }
  return {area2, width / std::abs(glm::dot(dir, n) / area2)};
}

// The texture's value at the hit: its texture coordinates interpolated
// and transformed, at the footprint's level of detail.
glm::dvec4 sample_at(const Scene& scene, const Mesh& mesh, const TextureRef& ref, const uint32_t i[3], double b0,
                     double u, double v, const Footprint& f) {
  const TextureImage& image = *scene.images[ref.image];
  const std::vector<glm::vec2>& t = mesh.attributes.texcoords[ref.texcoord];
  glm::dvec2 c[3] = {glm::dvec2(0.0), glm::dvec2(0.0), glm::dvec2(0.0)};
  if (!t.empty())
    for (int k = 0; k < 3; ++k) c[k] = glm::dvec2(ref.uv_transform * glm::dvec3(glm::dvec2(t[i[k]]), 1.0));
  const glm::dvec2 e1 = c[1] - c[0], e2 = c[2] - c[0];
  const double texels = std::abs(e1.x * e2.y - e1.y * e2.x) * image.levels[0].width * image.levels[0].height;
  const double lod = 0.5 * std::log2(texels / f.world_area2) + std::log2(f.width);
  return sample_texture(image, ref.sampler, interpolate(c[0], c[1], c[2], b0, u, v), lod);
}

// Whether the triangle's material reads a texture.
bool textured(const Scene& scene, const Mesh& mesh, uint32_t tri) {
  if (mesh.attributes.materials.empty()) return false;
  const uint32_t m = mesh.attributes.materials[tri];
  if (m >= scene.materials.size()) return false;
  return scene.materials[m].textured();
}

// sample_at, or (1, 1, 1, 1) without a texture: checked here, inline,
// since most materials have none.
inline glm::dvec4 lookup(const Scene& scene, const Mesh& mesh, const TextureRef& ref, const uint32_t i[3], double b0,
                         double u, double v, const Footprint& f) {
  return ref.image < 0 ? glm::dvec4(1.0) : sample_at(scene, mesh, ref, i, b0, u, v, f);
}

// What the pixels on one triangle of one instance read of its corners,
// worked out once for a run of them.
struct CornerWants {
  bool object = false, world = false, normals = false, texcoord[2] = {false, false};
};
struct Corners {
  uint32_t inst = RF_INVALID, tri = RF_INVALID;
  const Mesh* mesh = nullptr;
  bool vertices = false;  // the rest is filled (fill_corners)
  uint32_t i[3] = {0, 0, 0};
  glm::dvec3 object[3], world[3];  // positions: the mesh's own, world_from_object's of them
  glm::dvec3 normal[3];            // NORMAL through normal_from_object (not unit)
  bool flat = true;                // a corner without a normal: the geometric normal stands in
  glm::dvec2 texcoord[2][3];       // (0, 0) where the mesh has none
};

void fill_corners(Corners& c, const InstanceXforms& x, const CornerWants& wants) {
  const Mesh& mesh = *c.mesh;
  for (int k = 0; k < 3; ++k) c.i[k] = mesh.indices[3 * c.tri + k];
  for (int k = 0; k < 3; ++k) {
    if (wants.object || wants.world) c.object[k] = glm::dvec3(mesh.positions[c.i[k]]);
    if (wants.world) c.world[k] = glm::dvec3(x.world_from_object * glm::dvec4(c.object[k], 1.0));
  }
  if (wants.normals) {
    const std::vector<glm::vec3>& n = mesh.attributes.normals;
    c.flat = n.empty() || zero(n[c.i[0]]) || zero(n[c.i[1]]) || zero(n[c.i[2]]);
    if (!c.flat)
      for (int k = 0; k < 3; ++k) c.normal[k] = x.normal_from_object * glm::dvec3(n[c.i[k]]);
  }
  for (int set = 0; set < 2; ++set) {
    if (!wants.texcoord[set]) continue;
    const std::vector<glm::vec2>& t = mesh.attributes.texcoords[set];
    for (int k = 0; k < 3; ++k) c.texcoord[set][k] = t.empty() ? glm::dvec2(0.0) : glm::dvec2(t[c.i[k]]);
  }
}

// Duff et al. 2017's perpendicular of the unit vector n.
glm::dvec3 perpendicular(const glm::dvec3& n) {
  const double sign = std::copysign(1.0, n.z);
  const double a = -1.0 / (sign + n.z), b = n.x * n.y * a;
  return glm::dvec3(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
}

// The tangent plane's value at the hit (resolve.h's ResolvedPlanes::tangent).
// `found`: whether the tangent came from the mesh's, not the stand-in.
glm::dvec4 tangent_at(const Mesh& mesh, uint32_t tri, double b0, double u, double v, const InstanceXforms& x,
                      const glm::dvec3& normal, bool* found) {
  const std::vector<glm::vec4>& t = mesh.attributes.tangents;
  glm::dvec4 corner(0.0, 0.0, 0.0, 1.0);
  if (!t.empty())
    corner = interpolate(glm::dvec4(t[3 * tri]), glm::dvec4(t[3 * tri + 1]), glm::dvec4(t[3 * tri + 2]), b0, u, v);
  const glm::dvec3 world = glm::dmat3(x.world_from_object) * glm::dvec3(corner);
  glm::dvec3 tangent = world - normal * glm::dot(normal, world);
  const double length = glm::length(tangent);
  *found = length > 0.0 && std::isfinite(length);
  if (*found)
    tangent /= length;
  else
    tangent = perpendicular(normal);
  return glm::dvec4(tangent, (corner.w < 0.0 ? -1.0 : 1.0) * x.handedness);
}

}  // namespace

unsigned attributes_read(const ResolvedPlanes& out) {
  const bool material_data = out.base_color || out.metallic_roughness || out.emissive;
  const unsigned frame = out.tangent || out.mapped_normal ? kAttributeNormal | kAttributeTangent : 0u;
  const unsigned normal_texture =
      out.mapped_normal ? kAttributeMaterial | kAttributeNormalTexture | kAttributeTexcoord0 | kAttributeTexcoord1 : 0u;
  return frame | normal_texture | (out.shading_normal ? kAttributeNormal : 0u) |
         (out.texcoord[0] ? kAttributeTexcoord0 : 0u) | (out.texcoord[1] ? kAttributeTexcoord1 : 0u) |
         (out.material ? kAttributeMaterial : 0u) |
         (material_data ? kAttributeMaterial | kAttributeMaterialData | kAttributeTexcoord0 | kAttributeTexcoord1
                        : 0u) |
         (out.base_color ? kAttributeColor0 : 0u) | (out.label ? kAttributeLabel : 0u);
}

RayCone ray_cone(const Camera& camera) {
  RayCone cone;
  cone.orthographic = is_orthographic(camera);
  cone.eye = glm::dvec3(camera.world_from_camera * glm::dvec4(0.0, 0.0, 0.0, 1.0));
  cone.forward = glm::normalize(glm::dvec3(camera.world_from_camera * glm::dvec4(0.0, 0.0, -1.0, 0.0)));
  cone.spread = pixel_angle(camera);
  const int x = camera.width / 2, y = camera.height / 2;
  cone.width = glm::length(exact_origin(camera, x + 1, y) - exact_origin(camera, x, y));
  return cone;
}

void resolve(const Scene& scene, const HitPlanes& in, const RayCone& cone, const ResolvedPlanes& out,
             unsigned threads) {
  RF_CHECK(in.instance && in.primitive && in.barycentrics, "the resolve needs the hits' ids and barycentrics");
  RF_CHECK(!(out.shading_normal || out.tangent || out.mapped_normal) || in.normal,
           "shading normals need the geometric normal as their stand-in");
  std::vector<InstanceXforms> xforms(scene.instances.size());
  for (size_t i = 0; i < xforms.size(); ++i) {
    const Xform& m = scene.instances[i].world_from_object;
    xforms[i] = {m, glm::transpose(glm::inverse(glm::dmat3(m))), glm::determinant(glm::dmat3(m)) < 0.0 ? -1.0 : 1.0};
  }
  const bool frame = out.tangent || out.mapped_normal;
  const bool per_vertex =
      out.position || out.object_position || out.shading_normal || frame || out.texcoord[0] || out.texcoord[1];
  CornerWants wants;
  wants.object = out.position || out.object_position;
  wants.world = out.position || out.base_color || out.metallic_roughness || out.emissive || out.mapped_normal;
  wants.normals = out.shading_normal || frame;
  wants.texcoord[0] = out.texcoord[0] != nullptr;
  wants.texcoord[1] = out.texcoord[1] != nullptr;
  parallel_for(in.pixels, threads, size_t{1} << 13, [&](size_t begin, size_t end) {
    Corners c;
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
        clear(out.base_color, 4);
        clear(out.metallic_roughness, 2);
        clear(out.emissive, 3);
        clear(out.tangent, 4);
        clear(out.mapped_normal, 3);
        if (out.material) out.material[p] = RF_INVALID;
        if (out.label) out.label[p] = RF_INVALID;
        continue;
      }
      // Neighbouring pixels mostly hit one triangle: its corners, moved to
      // world space, are worked out once for the run of pixels on it.
      if (inst != c.inst || in.primitive[p] != c.tri) {
        RF_CHECK_LT(inst, scene.instances.size(), "a hit on an instance the scene does not have");
        c.mesh = &scene.meshes[scene.instances[inst].mesh];
        c.tri = in.primitive[p];
        c.inst = inst;
        RF_CHECK_LT(c.tri, c.mesh->triangle_count(), "a hit on a triangle its mesh does not have");
        // The triangle's vertices are read only by the channels that need
        // them: a scattered read that costs more than the rest of a material
        // channel whose factors alone make it.
        c.vertices = per_vertex || out.base_color ||
                     ((out.metallic_roughness || out.emissive || out.mapped_normal) && textured(scene, *c.mesh, c.tri));
        if (c.vertices) fill_corners(c, xforms[inst], wants);
      }
      const Mesh& mesh = *c.mesh;
      const uint32_t tri = c.tri;
      const double u = in.barycentrics[2 * p], v = in.barycentrics[2 * p + 1];
      const double b0 = (1.0 - u) - v;
      const InstanceXforms& x = xforms[inst];
      if (out.object_position) {
        const glm::dvec3 o = interpolate(c.object[0], c.object[1], c.object[2], b0, u, v);
        for (int k = 0; k < 3; ++k) out.object_position[3 * p + k] = static_cast<float>(o[k]);
      }
      if (out.position) {
        const glm::dvec3 w = interpolate(c.world[0], c.world[1], c.world[2], b0, u, v);
        for (int k = 0; k < 3; ++k) out.position[3 * p + k] = static_cast<float>(w[k]);
      }
      // The shading normal, in double for the tangent frame.
      glm::dvec3 shading(0.0);
      if (out.shading_normal || frame) {
        bool flat = c.flat;
        if (!flat) {
          shading = interpolate(c.normal[0], c.normal[1], c.normal[2], b0, u, v);
          const double length = std::sqrt(shading.x * shading.x + shading.y * shading.y + shading.z * shading.z);
          flat = !(length > 0.0) || !std::isfinite(length);
          shading /= length;
        }
        if (flat) shading = glm::dvec3(in.normal[3 * p], in.normal[3 * p + 1], in.normal[3 * p + 2]);
        if (out.shading_normal)
          for (int k = 0; k < 3; ++k) out.shading_normal[3 * p + k] = static_cast<float>(shading[k]);
      }
      glm::dvec4 tangent(0.0);
      bool has_tangent = false;
      if (frame) {
        tangent = tangent_at(mesh, tri, b0, u, v, x, shading, &has_tangent);
        if (out.tangent)
          for (int k = 0; k < 4; ++k) out.tangent[4 * p + k] = static_cast<float>(tangent[k]);
      }
      for (int set = 0; set < 2; ++set) {
        if (!out.texcoord[set]) continue;
        const glm::dvec2 tc = interpolate(c.texcoord[set][0], c.texcoord[set][1], c.texcoord[set][2], b0, u, v);
        out.texcoord[set][2 * p] = static_cast<float>(tc.x);
        out.texcoord[set][2 * p + 1] = static_cast<float>(tc.y);
      }
      const uint32_t material = mesh.attributes.materials.empty() ? kDefaultMaterial : mesh.attributes.materials[tri];
      if (out.material) out.material[p] = material;
      if (out.label) out.label[p] = scene.instances[inst].label;
      if (out.base_color || out.metallic_roughness || out.emissive || out.mapped_normal) {
        const Material& m = material < scene.materials.size() ? scene.materials[material] : default_material();
        const uint32_t* corners = c.i;
        const uint32_t i0 = c.i[0], i1 = c.i[1], i2 = c.i[2];
        // The footprint only where a texture is read: factors alone need none.
        Footprint f{0.0, 0.0};
        if (m.textured()) f = footprint(cone, c.world, interpolate(c.world[0], c.world[1], c.world[2], b0, u, v));
        if (out.base_color) {
          const std::vector<glm::vec4>& colors = mesh.attributes.colors;
          const glm::dvec4 color = colors.empty() ? glm::dvec4(1.0)
                                                  : interpolate(glm::dvec4(colors[i0]), glm::dvec4(colors[i1]),
                                                                glm::dvec4(colors[i2]), b0, u, v);
          const glm::dvec4 rgba = m.base_color_factor * color * lookup(scene, mesh, m.base_color, corners, b0, u, v, f);
          for (int k = 0; k < 4; ++k) out.base_color[4 * p + k] = static_cast<float>(rgba[k]);
        }
        if (out.metallic_roughness) {
          const glm::dvec4 t = lookup(scene, mesh, m.metallic_roughness, corners, b0, u, v, f);
          out.metallic_roughness[2 * p] = static_cast<float>(m.metallic_factor * t[2]);
          out.metallic_roughness[2 * p + 1] = static_cast<float>(m.roughness_factor * t[1]);
        }
        if (out.emissive) {
          const glm::dvec3 e = m.emissive_factor * glm::dvec3(lookup(scene, mesh, m.emissive, corners, b0, u, v, f)) *
                               m.emissive_strength;
          for (int k = 0; k < 3; ++k) out.emissive[3 * p + k] = static_cast<float>(e[k]);
        }
        if (out.mapped_normal) {
          glm::dvec3 mapped = shading;
          if (m.normal.image >= 0 && has_tangent) {
            const glm::dvec3 t = 2.0 * glm::dvec3(sample_at(scene, mesh, m.normal, corners, b0, u, v, f)) - 1.0;
            const glm::dvec3 tangent3(tangent);
            const glm::dvec3 bitangent = tangent.w * glm::cross(shading, tangent3);
            const glm::dvec3 sum =
                tangent3 * (t.x * m.normal_scale) + bitangent * (t.y * m.normal_scale) + shading * t.z;
            const double length = glm::length(sum);
            if (length > 0.0 && std::isfinite(length)) mapped = sum / length;
          }
          for (int k = 0; k < 3; ++k) out.mapped_normal[3 * p + k] = static_cast<float>(mapped[k]);
        }
      }
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
      {kAttributeTangent, "TANGENT nor the texture coordinates to make them from",
       "tangent is a perpendicular of the shading normal there and mapped_normal the shading normal"},
  };
  std::vector<std::string> out;
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const Mesh& mesh = scene.meshes[m];
    const std::string name = "mesh " + std::to_string(m) + (mesh.name.empty() ? "" : " ('" + mesh.name + "')");
    if (attributes & (kAttributeMaterialData | kAttributeNormalTexture)) {
      // A texture reading a coordinate set the mesh lacks samples (0, 0).
      std::set<uint32_t> used(mesh.attributes.materials.begin(), mesh.attributes.materials.end());
      for (uint32_t mi : used) {
        if (mi >= scene.materials.size()) continue;
        const Material& mat = scene.materials[mi];
        for (const TextureRef* t : mat.textures()) {
          const unsigned bit = t->texcoord == 0 ? kAttributeTexcoord0 : kAttributeTexcoord1;
          if (t->image < 0 || ((mesh.attributes.present & bit) && !(mesh.attributes.missing & bit))) continue;
          out.push_back(name + " lacks TEXCOORD_" + std::to_string(t->texcoord) +
                        " (in part or whole), which material " + std::to_string(mi) +
                        (mat.name.empty() ? "" : " ('" + mat.name + "')") +
                        "'s textures read: they are sampled at (0, 0) there");
          break;
        }
      }
    }
    for (const Stand& s : kStands) {
      if (!(attributes & s.bit)) continue;
      const bool none = !(mesh.attributes.loaded & s.bit) || !(mesh.attributes.present & s.bit);
      if (!none && !(mesh.attributes.missing & s.bit)) continue;
      out.push_back(name + (none ? " has no " : " has primitives without ") + s.attribute + ": " + s.instead +
                    (none && mesh.attributes.loaded == 0 ? " (a mesh built in memory or read from a scene file "
                                                           "keeps positions only)"
                                                         : ""));
    }
    // A primitive without a material has glTF's default one, said by
    // material_id; a mesh that kept no materials at all is named.
    if ((attributes & kAttributeMaterial) && mesh.attributes.loaded == 0)
      out.push_back(name +
                    " has no materials (a mesh built in memory or read from a scene file keeps positions "
                    "only): its material_id is DEFAULT_MATERIAL and its material channels glTF's default "
                    "material's");
  }
  return out;
}

}  // namespace rayfold::core
