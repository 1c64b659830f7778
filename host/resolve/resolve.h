// The G-buffer's resolve: from each pixel's hit (instance, primitive,
// barycentrics) the channels a visibility buffer does not hold, read from
// the scene's attributes (scene/attributes.h). Its values are defined here,
// on the host, and every backend and fold mode gives them bit for bit,
// since the hits they come from are.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "scene/camera.h"
#include "scene/scene.h"

namespace rayfold::core {

// One view's hits, as the trace's planes hold them (rf_types.h RF_PLANE_*).
struct HitPlanes {
  size_t pixels = 0;
  const uint32_t* instance = nullptr;   // the scene's instance, RF_INVALID on a miss
  const uint32_t* primitive = nullptr;  // triangle index in the instance's mesh
  const float* barycentrics = nullptr;  // 2 per pixel: the weights u, v of the second and third vertex
  const float* normal = nullptr;        // 3 per pixel: the geometric normal (shading normals' stand-in); may be null
};

// The view's rays as cones, for the texture lookups' level of detail
// (Akenine-Moller et al., "Texture Level of Detail Strategies for
// Real-Time Ray Tracing", Ray Tracing Gems, 2019): a pixel's footprint at
// the hit is W = spread * |hit - eye| wide (orthographic: `width`), seen
// at the angle theta between its ray and the triangle's normal, and the
// level is lod = 1/2 log2(texel area / world area of the triangle) +
// log2(W / |cos theta|), both areas from the triangle's corners (texture
// coordinates after KHR_texture_transform, times the image's size; world
// positions in double).
struct RayCone {
  bool orthographic = false;
  glm::dvec3 eye{0.0};                 // perspective: every ray's origin
  glm::dvec3 forward{0.0, 0.0, -1.0};  // orthographic: every ray's direction
  double spread = 0.0;                 // perspective: the angle between neighbouring rays at the image centre
  double width = 0.0;                  // orthographic: a pixel's width, world units
};
RayCone ray_cone(const Camera& camera);

// Where the resolved channels go, each null when not asked for; every one
// is 0 on a miss but material (RF_INVALID). Every float is computed in
// double from the file's float values and rounded once, with the first
// vertex's weight b0 = (1 - u) - v (the interpolation b0 a0 + u a1 + v a2,
// summed in that order):
struct ResolvedPlanes {
  // 3: the corners' world positions (world_from_object times each, in
  // double) interpolated: once per triangle for the run of pixels on it.
  float* position = nullptr;
  float* object_position = nullptr;  // 3: the interpolated position in the mesh's own space
  // 3: the corners' NORMALs through world_from_object's inverse transpose,
  // interpolated, unit length; the geometric normal (HitPlanes::normal)
  // where a vertex of the triangle has none (glTF: flat shading) or the
  // result has no length.
  float* shading_normal = nullptr;
  float* texcoord[2] = {nullptr, nullptr};  // 2: TEXCOORD_0 and _1 interpolated; (0, 0) where the mesh has none
  uint32_t* material = nullptr;             // 1: the glTF material index, kDefaultMaterial where none is named
  // The material's values at the hit (glTF 2.0, 3.9; glTF's default
  // material where the primitive names none), each texture sampled with
  // its sampler at the ray cone's level of detail (texture_sampling.h),
  // sRGB textures decoded to linear first:
  float* base_color = nullptr;          // 4: baseColorFactor * COLOR_0 * baseColorTexture, linear RGBA
  float* metallic_roughness = nullptr;  // 2: metallicFactor * texture B, roughnessFactor * texture G
  float* emissive = nullptr;            // 3: emissiveFactor * emissiveTexture * emissiveStrength, linear RGB
  uint32_t* label = nullptr;            // 1: the instance's index into Scene::labels (RF_INVALID on a miss)
  // 4: the corners' tangents (MeshAttributes::tangents) through
  // world_from_object's linear part, interpolated, less their part along the shading
  // normal, unit length; where that leaves no length (no tangent), the
  // perpendicular of Duff et al. 2017 ("Building an Orthonormal Basis,
  // Revisited"). Then w: the sign of the interpolated w times that of the
  // linear part's determinant (a mirroring transform flips the frame).
  float* tangent = nullptr;
  // 3: with B = w cross(N, T) from the shading normal N and that tangent
  // frame, the normalTexture's (r, g, b) sampled as the material channels'
  // textures: normalize(T x s + B y s + N z) with (x, y, z) = 2 (r, g, b) -
  // 1 and s the texture's scale; N where the material has no normal
  // texture, the mesh no tangent there (the stand-in above), or the sum no
  // length.
  float* mapped_normal = nullptr;
};

// Triangle `tri` of `mesh`'s corners moved to world space by
// world_from_object, in double: what the position channel and the flow
// interpolate.
void world_corners(const Mesh& mesh, uint32_t tri, const Xform& world_from_object, glm::dvec3 out[3]);

// The attributes the planes of `out` read (Attribute bits).
unsigned attributes_read(const ResolvedPlanes& out);

// Resolves every pixel of `in` into `out` on `threads` threads (0: every
// core). The scene's meshes hold the attributes attributes_read names
// (LoadOptions::attributes); a mesh lacking one gets the stand-ins above.
// The material channels read `cone`.
void resolve(const Scene& scene, const HitPlanes& in, const RayCone& cone, const ResolvedPlanes& out, unsigned threads);

// One line for each mesh that lacks, in part or whole, an attribute among
// `attributes` (Attribute bits), saying what its pixels get instead.
std::vector<std::string> missing_attribute_warnings(const Scene& scene, unsigned attributes);

}  // namespace rayfold::core
