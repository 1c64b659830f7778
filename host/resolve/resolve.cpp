#include "resolve/resolve.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <set>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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

// What a texture lookup reads of a hit's triangle, worked out once for the
// run of pixels on it: its world-space normal (not unit) and twice its area,
// and per texture of its material (Material::textures()'s order) the
// corners' texture coordinates, transformed, and the part of the level of
// detail that does not vary over it (resolve.h's RayCone).
struct Footprint {
  glm::dvec3 normal;
  double area2;
  struct Texture {
    glm::dvec2 uv[3];
    double lod_base;  // 1/2 log2(texel area / world area)
  } textures[4];
};

Footprint footprint(const Scene& scene, const Mesh& mesh, const Material& m, const uint32_t i[3],
                    const glm::dvec3 w[3]) {
  Footprint f;
  f.normal = glm::cross(w[1] - w[0], w[2] - w[0]);
  f.area2 = glm::length(f.normal);
  const std::array<const TextureRef*, 4> refs = m.textures();
  for (size_t k = 0; k < refs.size(); ++k) {
    const TextureRef& ref = *refs[k];
    if (ref.image < 0) continue;
    const TextureImage& image = *scene.images[ref.image];
    const std::vector<glm::vec2>& t = mesh.attributes.texcoords[ref.texcoord];
    glm::dvec2* c = f.textures[k].uv;
    for (int j = 0; j < 3; ++j)
      c[j] = t.empty() ? glm::dvec2(0.0) : glm::dvec2(ref.uv_transform * glm::dvec3(glm::dvec2(t[i[j]]), 1.0));
    const glm::dvec2 e1 = c[1] - c[0], e2 = c[2] - c[0];
    const double texels = std::abs(e1.x * e2.y - e1.y * e2.x) * image.levels[0].width * image.levels[0].height;
    f.textures[k].lod_base = 0.5 * std::log2(texels / f.area2);
  }
  return f;
}

// The cone's footprint at the hit over the cosine of its angle with the
// triangle: W / |cos theta|.
double footprint_width(const RayCone& cone, const Footprint& f, const glm::dvec3& hit) {
  glm::dvec3 dir = cone.forward;
  double width = cone.width;
  if (!cone.orthographic) {
    const double t = glm::length(hit - cone.eye);
    width = cone.spread * t;
    dir = (hit - cone.eye) / t;
  }
  return width / std::abs(glm::dot(dir, f.normal) / f.area2);
}

// Texture k of the material (Footprint's order) at the hit: its texture
// coordinates interpolated, at the footprint's level of detail.
glm::dvec4 sample_at(const Scene& scene, const TextureRef& ref, const Footprint& f, size_t k, double b0, double u,
                     double v, double width) {
  const Footprint::Texture& t = f.textures[k];
  return sample_texture(*scene.images[ref.image], ref.sampler, interpolate(t.uv[0], t.uv[1], t.uv[2], b0, u, v),
                        t.lod_base + std::log2(width));
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
inline glm::dvec4 lookup(const Scene& scene, const TextureRef& ref, const Footprint& f, size_t k, double b0, double u,
                         double v, double width) {
  return ref.image < 0 ? glm::dvec4(1.0) : sample_at(scene, ref, f, k, b0, u, v, width);
}

// What the pixels on one triangle of one instance read of its corners,
// worked out once for a run of them.
struct CornerWants {
  bool object = false, world = false, normals = false, tangents = false, texcoord[2] = {false, false};
};
struct Corners {
  uint32_t inst = RF_INVALID, tri = RF_INVALID;
  const Mesh* mesh = nullptr;
  bool vertices = false;  // the rest is filled (fill_corners)
  uint32_t i[3] = {0, 0, 0};
  glm::dvec3 object[3], world[3];  // positions: the mesh's own, world_from_object's of them
  glm::dvec3 normal[3];            // NORMAL through normal_from_object (not unit)
  bool flat = true;                // a corner without a normal: the geometric normal stands in
  glm::dvec4 tangent[3];           // the corners' tangents through world_from_object's linear part, and w
  bool no_tangent = true;          // every corner's tangent is (0, 0, 0), the stand-in where a mesh has none
  glm::dvec2 texcoord[2][3];       // (0, 0) where the mesh has none
};

void fill_corners(Corners& c, const InstanceXforms& x, const CornerWants& wants) {
  const Mesh& mesh = *c.mesh;
  for (int k = 0; k < 3; ++k) c.i[k] = mesh.indices[3 * c.tri + k];
  if (wants.object)
    for (int k = 0; k < 3; ++k) c.object[k] = glm::dvec3(mesh.positions[c.i[k]]);
  if (wants.world) world_corners(mesh, c.tri, x.world_from_object, c.world);
  if (wants.normals) {
    const std::vector<glm::vec3>& n = mesh.attributes.normals;
    c.flat = n.empty() || zero(n[c.i[0]]) || zero(n[c.i[1]]) || zero(n[c.i[2]]);
    if (!c.flat)
      for (int k = 0; k < 3; ++k) c.normal[k] = x.normal_from_object * glm::dvec3(n[c.i[k]]);
  }
  if (wants.tangents) {
    const std::vector<glm::vec4>& t = mesh.attributes.tangents;
    const glm::dmat3 linear(x.world_from_object);
    for (int k = 0; k < 3; ++k) {
      const glm::dvec4 corner = t.empty() ? glm::dvec4(0.0, 0.0, 0.0, 1.0) : glm::dvec4(t[3 * c.tri + k]);
      c.tangent[k] = glm::dvec4(linear * glm::dvec3(corner), corner.w);
    }
    c.no_tangent = t.empty() || (zero(glm::vec3(t[3 * c.tri])) && zero(glm::vec3(t[3 * c.tri + 1])) &&
                                 zero(glm::vec3(t[3 * c.tri + 2])));
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

// The tangent plane's value at the hit (resolve.h's ResolvedPlanes::tangent)
// from the corners' (Corners::tangent). `found`: whether the tangent came
// from the mesh's, not the stand-in.
glm::dvec4 tangent_at(const Corners& c, double b0, double u, double v, double handedness, const glm::dvec3& normal,
                      bool* found) {
  const glm::dvec4 world = interpolate(c.tangent[0], c.tangent[1], c.tangent[2], b0, u, v);
  if (c.no_tangent) {  // what the lines below give zero corners, without a square root a pixel to wait for
    *found = false;
    return glm::dvec4(perpendicular(normal), (world.w < 0.0 ? -1.0 : 1.0) * handedness);
  }
  glm::dvec3 tangent = glm::dvec3(world) - normal * glm::dot(normal, glm::dvec3(world));
  const double length = glm::length(tangent);
  *found = length > 0.0 && std::isfinite(length);
  if (*found)
    tangent /= length;
  else
    tangent = perpendicular(normal);
  return glm::dvec4(tangent, (world.w < 0.0 ? -1.0 : 1.0) * handedness);
}

}  // namespace

void world_corners(const Mesh& mesh, uint32_t tri, const Xform& world_from_object, glm::dvec3 out[3]) {
  for (int k = 0; k < 3; ++k)
    out[k] = glm::dvec3(world_from_object * glm::dvec4(glm::dvec3(mesh.positions[mesh.indices[3 * tri + k]]), 1.0));
}

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

namespace {

// The shading normal at (b0, u, v): the corners' normals interpolated, unit
// length; `geometric` (the hit's) where a corner has none or the sum no length.
inline glm::dvec3 shading_at(const Corners& c, double b0, double u, double v, const float* geometric) {
  if (!c.flat) {
    const glm::dvec3 s = interpolate(c.normal[0], c.normal[1], c.normal[2], b0, u, v);
    const double length = std::sqrt(s.x * s.x + s.y * s.y + s.z * s.z);
    if (length > 0.0 && std::isfinite(length)) return s / length;
  }
  return glm::dvec3(geometric[0], geometric[1], geometric[2]);
}

// A machine with AVX2 runs the loop below in 4 lanes of doubles, another
// one pixel at a time (gcc does not vectorise it for SSE2); the same
// operations in the same order in each, so the same bits.
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define RF_VECTOR_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define RF_VECTOR_CLONES
#endif

// A chunk's sums of interpolated normals (shading_at's before its division),
// one array per component: the pass below reads each as consecutive lanes
// (interleaved, taking them apart was half its time: 4.6 against 2.1 ns a
// pixel on an AVX2 EPYC, the same bits).
struct NormalSums {
  double* x = nullptr;  // x[i], y[i], z[i]: the chunk's i-th pixel's sum
  double* y = nullptr;
  double* z = nullptr;
  void set(size_t i, const glm::dvec3& s) const {
    x[i] = s.x;
    y[i] = s.y;
    z[i] = s.z;
  }
  void zero(size_t i, size_t j) const {
    for (double* c : {x, y, z}) std::fill(c + i, c + j, 0.0);
  }
  explicit operator bool() const { return x != nullptr; }
};

// shading_at's last steps for the pixels [0, n) of a chunk whose runs have
// left each pixel's sum of interpolated normals in `sums`: the length, and
// the sum divided by it. Returns how many sums had no length
// (0 or not finite), whose pixels the caller gives the geometric normal.
// One pass over the chunk in vector lanes, where a pass per run was mostly
// its remainder: runs are short (Sponza's median 2 pixels at 1280x720).
// Every lane divides (by 1 where the sum has no length), so that nothing is
// conditional; a lane's operations are a lone pixel's (correctly rounded
// square root and division, no contraction). The geometric normal is not
// chosen here: gcc 12.2 vectorised that select (doubles' masks on floats
// stored 3 apart) into lanes that took the wrong side.
RF_VECTOR_CLONES size_t normalize_sums(const NormalSums& sums, float* out, size_t n) {
  const double* const xs = sums.x;
  const double* const ys = sums.y;
  const double* const zs = sums.z;
  size_t stand_ins = 0;
#pragma omp simd reduction(+ : stand_ins)
  for (size_t p = 0; p < n; ++p) {
    const double x = xs[p], y = ys[p], z = zs[p];
    const double length = std::sqrt(x * x + y * y + z * z);
    const bool unit = (length > 0.0) & (length <= std::numeric_limits<double>::max());  // > 0 and finite
    const double d = unit ? length : 1.0;
    out[3 * p] = static_cast<float>(x / d);
    out[3 * p + 1] = static_cast<float>(y / d);
    out[3 * p + 2] = static_cast<float>(z / d);
    stand_ins += unit ? 0 : 1;
  }
  return stand_ins;
}

// The end of the run of pixels from `a` (< end) that hit triangle `tri` of
// instance `inst`, as pixel a does. Runs are short (Sponza's median 2
// pixels), so a loop a pixel at a time left a mispredicted branch at every
// run's end; four pixels are compared at once where SSE2 is.
inline size_t run_end(const HitPlanes& in, size_t a, size_t end, uint32_t inst, uint32_t tri) {
  size_t b = a + 1;
#if defined(__SSE2__)
  const __m128i want_inst = _mm_set1_epi32(static_cast<int>(inst)), want_tri = _mm_set1_epi32(static_cast<int>(tri));
  for (; b + 4 <= end; b += 4) {
    const __m128i insts = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in.instance + b));
    const __m128i tris = _mm_loadu_si128(reinterpret_cast<const __m128i*>(in.primitive + b));
    const __m128i same = _mm_and_si128(_mm_cmpeq_epi32(insts, want_inst), _mm_cmpeq_epi32(tris, want_tri));
    const unsigned mask = static_cast<unsigned>(_mm_movemask_ps(_mm_castsi128_ps(same)));
    if (mask != 0xFu) return b + static_cast<size_t>(__builtin_ctz(~mask));
  }
#endif
  while (b < end && in.instance[b] == inst && in.primitive[b] == tri) ++b;
  return b;
}

template <int N, class V>
inline void store(float* plane, size_t p, const V& value) {
  for (int k = 0; k < N; ++k) plane[N * p + k] = static_cast<float>(value[k]);
}

// One call's resolve: the scene, the hits and the planes, and what each
// run of pixels on one triangle reads.
struct Resolver {
  const Scene& scene;
  const HitPlanes& in;
  const RayCone& cone;
  const ResolvedPlanes& out;
  std::vector<InstanceXforms> xforms;
  CornerWants wants;
  bool frame = false, per_vertex = false, material_data = false;
  bool samples = false;  // a channel that reads a material's textures (material data, mapped_normal)

  Resolver(const Scene& s, const HitPlanes& h, const RayCone& r, const ResolvedPlanes& o)
      : scene(s), in(h), cone(r), out(o), xforms(s.instances.size()) {
    for (size_t i = 0; i < xforms.size(); ++i) {
      const Xform& m = scene.instances[i].world_from_object;
      xforms[i] = {m, glm::transpose(glm::inverse(glm::dmat3(m))), glm::determinant(glm::dmat3(m)) < 0.0 ? -1.0 : 1.0};
    }
    frame = out.tangent || out.mapped_normal;
    per_vertex =
        out.position || out.object_position || out.shading_normal || frame || out.texcoord[0] || out.texcoord[1];
    material_data = out.base_color || out.metallic_roughness || out.emissive;
    samples = material_data || out.mapped_normal;
    wants.object = out.position || out.object_position;
    wants.normals = out.shading_normal || frame;
    wants.tangents = frame;
    wants.texcoord[0] = out.texcoord[0] != nullptr;
    wants.texcoord[1] = out.texcoord[1] != nullptr;
  }

  double u(size_t p) const { return in.barycentrics[2 * p]; }
  double v(size_t p) const { return in.barycentrics[2 * p + 1]; }
  double b0(size_t p) const { return (1.0 - u(p)) - v(p); }  // the first vertex's weight

  // Pixels [a, b) that hit nothing: 0, and RF_INVALID for the ids.
  void clear(size_t a, size_t b) const {
    auto zero = [&](float* plane, size_t n) {
      if (plane) std::fill(plane + n * a, plane + n * b, 0.0f);
    };
    zero(out.position, 3);
    zero(out.object_position, 3);
    zero(out.shading_normal, 3);
    zero(out.texcoord[0], 2);
    zero(out.texcoord[1], 2);
    zero(out.base_color, 4);
    zero(out.metallic_roughness, 2);
    zero(out.emissive, 3);
    zero(out.tangent, 4);
    zero(out.mapped_normal, 3);
    if (out.material) std::fill(out.material + a, out.material + b, RF_INVALID);
    if (out.label) std::fill(out.label + a, out.label + b, RF_INVALID);
  }

  // Pixels [a, b), every one on triangle c.tri of instance c.inst: each
  // channel in a loop of its own over them.
  // sums: the shading normal's sums of the chunk's pixels from `first` on
  // (normalize_sums), when that channel is asked for without the tangent
  // frame; else null.
  void run(const Corners& c, size_t a, size_t b, const NormalSums& sums, size_t first) const {
    const Mesh& mesh = *c.mesh;
    const uint32_t material = mesh.attributes.materials.empty() ? kDefaultMaterial : mesh.attributes.materials[c.tri];
    if (out.material) std::fill(out.material + a, out.material + b, material);
    if (out.label) std::fill(out.label + a, out.label + b, scene.instances[c.inst].label);
    if (out.object_position)
      for (size_t p = a; p < b; ++p)
        store<3>(out.object_position, p, interpolate(c.object[0], c.object[1], c.object[2], b0(p), u(p), v(p)));
    if (out.position)
      for (size_t p = a; p < b; ++p)
        store<3>(out.position, p, interpolate(c.world[0], c.world[1], c.world[2], b0(p), u(p), v(p)));
    for (int set = 0; set < 2; ++set)
      if (out.texcoord[set])
        for (size_t p = a; p < b; ++p)
          store<2>(out.texcoord[set], p,
                   interpolate(c.texcoord[set][0], c.texcoord[set][1], c.texcoord[set][2], b0(p), u(p), v(p)));
    if (sums) {    // the shading normal's sums; normalize_sums divides them
      if (c.flat)  // no sum: the caller copies the geometric normal there
        sums.zero(a - first, b - first);
      else
        for (size_t p = a; p < b; ++p)
          sums.set(p - first, interpolate(c.normal[0], c.normal[1], c.normal[2], b0(p), u(p), v(p)));
    }
    if (!frame && !material_data) return;
    const Material& m = material < scene.materials.size() ? scene.materials[material] : default_material();
    if (frame && !material_data && (!out.mapped_normal || m.normal.image < 0)) {
      // The tangent frame with no normal texture to apply: a loop of its
      // own, mapped_normal the shading normal.
      for (size_t p = a; p < b; ++p) {
        glm::dvec4 tangent;
        bool found;
        const glm::dvec3 shading = frame_at(c, p, b0(p), u(p), v(p), &tangent, &found);
        if (out.mapped_normal) store<3>(out.mapped_normal, p, shading);
      }
      return;
    }
    // Without a texture or vertex colours a material channel's value is
    // the same on the whole run: worked out at its first pixel.
    const bool texture = m.textured();
    Footprint f;
    if (texture && samples) f = footprint(scene, mesh, m, c.i, c.world);
    const bool varies = frame || texture || (out.base_color && !mesh.attributes.colors.empty());
    const size_t last = varies ? b : a + 1;
    for (size_t p = a; p < last; ++p) pixel(c, m, texture && samples ? &f : nullptr, p);
    for (size_t p = last; p < b; ++p) {
      if (out.base_color) std::copy_n(out.base_color + 4 * a, 4, out.base_color + 4 * p);
      if (out.metallic_roughness) std::copy_n(out.metallic_roughness + 2 * a, 2, out.metallic_roughness + 2 * p);
      if (out.emissive) std::copy_n(out.emissive + 3 * a, 3, out.emissive + 3 * p);
    }
  }

  // Pixel p's shading normal (returned, in double) and tangent into their
  // planes where asked; `found`: the tangent is the mesh's, not the stand-in.
  glm::dvec3 frame_at(const Corners& c, size_t p, double b0, double u, double v, glm::dvec4* tangent,
                      bool* found) const {
    const glm::dvec3 shading = shading_at(c, b0, u, v, in.normal + 3 * p);
    if (out.shading_normal) store<3>(out.shading_normal, p, shading);
    *tangent = tangent_at(c, b0, u, v, xforms[c.inst].handedness, shading, found);
    if (out.tangent) store<4>(out.tangent, p, *tangent);
    return shading;
  }

  // One pixel's tangent frame and material channels; `f`: the triangle's
  // footprint where m reads a texture, else null.
  void pixel(const Corners& c, const Material& m, const Footprint* f, size_t p) const {
    const Mesh& mesh = *c.mesh;
    const double u = this->u(p), v = this->v(p);
    const double b0 = (1.0 - u) - v;
    glm::dvec3 shading(0.0);
    glm::dvec4 tangent(0.0);
    bool has_tangent = false;
    if (frame) shading = frame_at(c, p, b0, u, v, &tangent, &has_tangent);
    if (!material_data && !out.mapped_normal) return;
    // The footprint only where a texture is read: factors alone need none.
    const double width = f ? footprint_width(cone, *f, interpolate(c.world[0], c.world[1], c.world[2], b0, u, v)) : 0.0;
    static const Footprint kNone{};
    const Footprint& at = f ? *f : kNone;
    if (out.base_color) {
      const std::vector<glm::vec4>& colors = mesh.attributes.colors;
      const glm::dvec4 color = colors.empty() ? glm::dvec4(1.0)
                                              : interpolate(glm::dvec4(colors[c.i[0]]), glm::dvec4(colors[c.i[1]]),
                                                            glm::dvec4(colors[c.i[2]]), b0, u, v);
      store<4>(out.base_color, p, m.base_color_factor * color * lookup(scene, m.base_color, at, 0, b0, u, v, width));
    }
    if (out.metallic_roughness) {
      const glm::dvec4 t = lookup(scene, m.metallic_roughness, at, 1, b0, u, v, width);
      out.metallic_roughness[2 * p] = static_cast<float>(m.metallic_factor * t[2]);
      out.metallic_roughness[2 * p + 1] = static_cast<float>(m.roughness_factor * t[1]);
    }
    if (out.emissive)
      store<3>(out.emissive, p,
               m.emissive_factor * glm::dvec3(lookup(scene, m.emissive, at, 2, b0, u, v, width)) * m.emissive_strength);
    if (out.mapped_normal) {
      glm::dvec3 mapped = shading;
      if (m.normal.image >= 0 && has_tangent) {
        const glm::dvec3 t = 2.0 * glm::dvec3(sample_at(scene, m.normal, at, 3, b0, u, v, width)) - 1.0;
        const glm::dvec3 tangent3(tangent);
        const glm::dvec3 bitangent = tangent.w * glm::cross(shading, tangent3);
        const glm::dvec3 sum = tangent3 * (t.x * m.normal_scale) + bitangent * (t.y * m.normal_scale) + shading * t.z;
        const double length = glm::length(sum);
        if (length > 0.0 && std::isfinite(length)) mapped = sum / length;
      }
      store<3>(out.mapped_normal, p, mapped);
    }
  }
};

}  // namespace

void resolve(const Scene& scene, const HitPlanes& in, const RayCone& cone, const ResolvedPlanes& out,
             unsigned threads) {
  RF_CHECK(in.instance && in.primitive && in.barycentrics, "the resolve needs the hits' ids and barycentrics");
  RF_CHECK(!(out.shading_normal || out.tangent || out.mapped_normal) || in.normal,
           "shading normals need the geometric normal as their stand-in");
  const Resolver r(scene, in, cone, out);
  // The shading normal's sums, per thread, for a chunk (normalize_sums).
  const bool deferred = out.shading_normal && !r.frame;
  constexpr size_t kChunk = size_t{1} << 13;
  parallel_for(in.pixels, threads, kChunk, [&](size_t begin, size_t end) {
    thread_local std::vector<double> chunk_sums;
    // The chunk's runs of flat triangles (the geometric normal), and how
    // many pixels missed: their sums are 0, which normalize_sums turns into
    // 0 (a miss's value, as clear wrote it) and the flat runs are copied over.
    thread_local std::vector<std::pair<size_t, size_t>> flats;
    size_t missed = 0;
    RF_CHECK_LE(end - begin, kChunk, "parallel_for handed out a chunk larger than asked for");
    if (deferred) chunk_sums.resize(3 * kChunk);
    NormalSums sums;  // pixel p's at p - begin
    if (deferred) sums = {chunk_sums.data(), chunk_sums.data() + kChunk, chunk_sums.data() + 2 * kChunk};
    flats.clear();
    Corners c;
    // Neighbouring pixels mostly hit one triangle: a run of them shares
    // its corners, moved to world space once, and each channel is a loop
    // of its own over the run.
    for (size_t a = begin, b; a < end; a = b) {
      const uint32_t inst = in.instance[a];
      b = a + 1;
      if (inst == RF_INVALID) {
        while (b < end && in.instance[b] == RF_INVALID) ++b;
        r.clear(a, b);
        if (sums) {
          sums.zero(a - begin, b - begin);
          missed += b - a;
        }
        continue;
      }
      const uint32_t tri = in.primitive[a];
      b = run_end(in, a, end, inst, tri);
      if (inst != c.inst || tri != c.tri) {
        RF_CHECK_LT(inst, scene.instances.size(), "a hit on an instance the scene does not have");
        c.mesh = &scene.meshes[scene.instances[inst].mesh];
        c.tri = tri;
        c.inst = inst;
        RF_CHECK_LT(c.tri, c.mesh->triangle_count(), "a hit on a triangle its mesh does not have");
        // The triangle's vertices are read only by the channels that need
        // them: a scattered read that costs more than the rest of a material
        // channel whose factors alone make it; world positions only for a
        // texture's footprint or the position plane.
        const bool texture = r.samples && textured(scene, *c.mesh, c.tri);
        CornerWants wants = r.wants;
        wants.world = out.position || texture;
        c.vertices = r.per_vertex || texture || (out.base_color && !c.mesh->attributes.colors.empty());
        if (c.vertices) fill_corners(c, r.xforms[inst], wants);
      }
      r.run(c, a, b, sums, begin);
      if (sums && c.flat) flats.emplace_back(a, b);
    }
    if (sums) {
      size_t known = missed;  // the pixels of misses and flat triangles
      for (const auto& [a, b] : flats) known += b - a;
      // A chunk of misses and flat triangles alone (a mesh without normals) has nothing to divide.
      if (known < end - begin && normalize_sums(sums, out.shading_normal + 3 * begin, end - begin) > known)
        for (size_t p = begin; p < end; ++p) {  // an interpolated sum without length: rare, looked for alone
          const double x = sums.x[p - begin], y = sums.y[p - begin], z = sums.z[p - begin];
          const double length = std::sqrt(x * x + y * y + z * z);
          if (!(length > 0.0 && std::isfinite(length)) && in.instance[p] != RF_INVALID)
            std::copy(in.normal + 3 * p, in.normal + 3 * p + 3, out.shading_normal + 3 * p);
        }
      for (const auto& [a, b] : flats)  // the geometric normal, floats to floats
        std::copy(in.normal + 3 * a, in.normal + 3 * b, out.shading_normal + 3 * a);
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
  // Each kind of stand-in is said once, with the meshes it applies to (the
  // first three named, the rest counted): the sports car's 1,075 meshes
  // without TEXCOORD_0 and TANGENT were 2,150 lines. `one` follows a mesh's
  // name, `many` a count of them.
  struct Finding {
    std::string one, many;
    std::vector<std::string> meshes;
  };
  std::vector<Finding> found;
  auto note = [&](const std::string& mesh, std::string one, std::string many) {
    for (Finding& f : found)
      if (f.one == one) {
        f.meshes.push_back(mesh);
        return;
      }
    found.push_back({std::move(one), std::move(many), {mesh}});
  };
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
          const std::string rest = " TEXCOORD_" + std::to_string(t->texcoord) + " (in part or whole), which material " +
                                   std::to_string(mi) + (mat.name.empty() ? "" : " ('" + mat.name + "')") +
                                   "'s textures read: they are sampled at (0, 0) there (docs/channels.md)";
          note(name, " lacks" + rest, " lack" + rest);
          break;
        }
      }
    }
    for (const Stand& s : kStands) {
      if (!(attributes & s.bit)) continue;
      const bool none = !(mesh.attributes.loaded & s.bit) || !(mesh.attributes.present & s.bit);
      if (!none && !(mesh.attributes.missing & s.bit)) continue;
      const std::string rest = std::string(s.attribute) + ": " + s.instead +
                               (none && mesh.attributes.loaded == 0 ? " (a mesh built in memory or read from a scene "
                                                                      "file keeps positions only)"
                                                                    : "") +
                               " (docs/channels.md)";
      note(name, (none ? " has no " : " has primitives without ") + rest,
           (none ? " have no " : " have primitives without ") + rest);
    }
    // A primitive without a material has glTF's default one, said by
    // material_id; a mesh that kept no materials at all is named.
    if ((attributes & kAttributeMaterial) && mesh.attributes.loaded == 0)
      note(name,
           " has no materials (a mesh built in memory or read from a scene file keeps positions only): its "
           "material_id is DEFAULT_MATERIAL and its material channels glTF's default material's (docs/channels.md)",
           " have no materials (a mesh built in memory or read from a scene file keeps positions only): their "
           "material_id is DEFAULT_MATERIAL and their material channels glTF's default material's "
           "(docs/channels.md)");
  }
  std::vector<std::string> out;
  for (const Finding& f : found) {
    if (f.meshes.size() == 1) {
      out.push_back(f.meshes[0] + f.one);
      continue;
    }
    std::string names;
    for (size_t i = 0; i < std::min<size_t>(3, f.meshes.size()); ++i) names += (i ? ", " : "") + f.meshes[i];
    out.push_back(std::to_string(f.meshes.size()) + " meshes (" + names + (f.meshes.size() > 3 ? ", ..." : "") + ")" +
                  f.many);
  }
  return out;
}

}  // namespace rayfold::core
