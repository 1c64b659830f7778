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

// Where the resolved channels go, each null when not asked for; every one
// is 0 on a miss but material (RF_INVALID). Every float is computed in
// double from the file's float values and rounded once, with the first
// vertex's weight b0 = (1 - u) - v (the interpolation b0 a0 + u a1 + v a2,
// summed in that order):
struct ResolvedPlanes {
  float* position = nullptr;         // 3: world_from_object times the interpolated object position
  float* object_position = nullptr;  // 3: the interpolated position in the mesh's own space
  // 3: the interpolated NORMAL through world_from_object's inverse
  // transpose, unit length; the geometric normal (HitPlanes::normal) where a
  // vertex of the triangle has none (glTF: flat shading) or the result has
  // no length.
  float* shading_normal = nullptr;
  float* texcoord[2] = {nullptr, nullptr};  // 2: TEXCOORD_0 and _1 interpolated; (0, 0) where the mesh has none
  uint32_t* material = nullptr;             // 1: the glTF material index, kDefaultMaterial where none is named
};

// The attributes the planes of `out` read (Attribute bits).
unsigned attributes_read(const ResolvedPlanes& out);

// Resolves every pixel of `in` into `out` on `threads` threads (0: every
// core). The scene's meshes hold the attributes attributes_read names
// (LoadOptions::attributes); a mesh lacking one gets the stand-ins above.
void resolve(const Scene& scene, const HitPlanes& in, const ResolvedPlanes& out, unsigned threads);

// One line for each mesh that lacks, in part or whole, an attribute among
// `attributes` (Attribute bits), saying what its pixels get instead.
std::vector<std::string> missing_attribute_warnings(const Scene& scene, unsigned attributes);

}  // namespace rayfold::core
