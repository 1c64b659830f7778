// A mesh's vertex attributes beyond its positions, and its triangles'
// materials: what the G-buffer's resolve (host/resolve/) reads for shading
// normals, texture coordinates and material ids. The loader reads them
// only when a render asks for a channel that reads them (Scene::meshes
// keep positions alone otherwise): a scene whose renders ask for none costs
// what it did before them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

namespace rayfold::core {

// Which attributes to read (LoadOptions::attributes), as bit flags.
enum Attribute : unsigned {
  kAttributeNormal = 1u,     // NORMAL (and its morph targets, skinned)
  kAttributeTexcoord0 = 2u,  // TEXCOORD_0
  kAttributeTexcoord1 = 4u,  // TEXCOORD_1
  kAttributeMaterial = 8u,   // each primitive's material index
  kAttributeColor0 = 16u,    // COLOR_0
  // The materials' factors and their base colour, metallic-roughness and
  // emissive textures with their images decoded (scene/materials.h;
  // Scene::materials, Scene::images), and the texture coordinate sets their
  // textures read.
  kAttributeMaterialData = 32u,
  kAttributeLabel = 64u,  // each instance's label from its node's extras (Scene::labels)
  // TANGENT (its morph targets, skinned), and MikkTSpace's tangents where a
  // primitive has none (scene/tangents.h): MeshAttributes::tangents.
  kAttributeTangent = 128u,
  // The materials (their factors) with their normalTexture's image
  // decoded: read only for the channels that apply it.
  kAttributeNormalTexture = 256u,
};

// A triangle's material where its primitive names none (glTF's default
// material).
constexpr uint32_t kDefaultMaterial = 0xFFFFFFFEu;

// One mesh's attributes, indexed as its positions (per vertex) or its
// triangles (materials). A vector is empty where `loaded` lacks its bit. A
// vertex of a primitive without the attribute holds the documented stand-in
// and its bit in `missing`: a normal of (0, 0, 0) (the resolve then takes
// the triangle's geometric normal, as glTF says of a primitive without
// normals), texture coordinates (0, 0), a colour (1, 1, 1, 1) (glTF: a
// primitive without COLOR_0 is white). Where no primitive of the mesh has
// the attribute (`present` lacks its bit) the vector is empty: the stand-in
// everywhere.
struct MeshAttributes {
  unsigned loaded = 0;                  // Attribute bits read for this mesh
  unsigned missing = 0;                 // Attribute bits some primitive of it lacked
  unsigned present = 0;                 // Attribute bits some primitive of it had
  std::vector<glm::vec3> normals;       // object space, as the file gives them (unit length there)
  std::vector<glm::vec2> texcoords[2];  // TEXCOORD_0 and TEXCOORD_1, as the file gives them (v downward)
  std::vector<glm::vec4> colors;        // COLOR_0, linear RGBA (a VEC3's alpha 1)
  // Per triangle corner (3 per triangle, as `indices`): the tangent xyz and
  // the bitangent's sign w in object space. Per corner, since MikkTSpace
  // gives the corners of one vertex on either side of a mirrored UV seam
  // different tangents; a corner without one (no texture coordinates, a
  // degenerate triangle alone at its vertex) holds (0, 0, 0, 1).
  std::vector<glm::vec4> tangents;
  std::vector<uint32_t> materials;      // per triangle: the glTF material index, or kDefaultMaterial
};

}  // namespace rayfold::core
