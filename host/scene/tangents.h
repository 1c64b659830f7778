// Tangents where a glTF primitive gives none: glTF 2.0 (3.7.2.1) asks for
// MikkTSpace's (Mikkelsen, "Simulation of Wrinkled Surfaces Revisited",
// 2008), the tangent frame Blender's and most bakers' normal maps were made
// in. Its rule, with its default settings, as implemented here:
//  - vertices with equal position, normal and texture coordinates are one
//    vertex (the file may have split them);
//  - each triangle's tangent is the direction of increasing u on it, its
//    orientation whether (u, v) winds as its corners do;
//  - a corner's tangent is the sum, over the triangles around its vertex
//    that reach it across shared edges with the same orientation, of each
//    triangle's tangent projected into the vertex normal's plane, unit
//    length, weighted by the triangle's angle at the vertex (also in that
//    plane), then made unit length; its w is +1 for one orientation, -1 for
//    the other (bitangent = w * cross(normal, tangent));
//  - a triangle without a tangent of its own (no area in uv or in space)
//    takes that of another group at the same vertex.
// The texture's v is taken upward (glTF's v points down: v is negated), so
// that a normal map's +y (up in the image) is the bitangent, as in glTF's
// sample viewer and the tangents Blender writes; w flips with it. Sums in
// double; the one place it departs from MikkTSpace's code is that: its
// float sums round differently (within a few float ulps of unit vectors).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

namespace rayfold::core {

// Per corner of the `triangles` triangles indices[3 t + k] (into the
// vertices' arrays): the tangent xyz, unit length, and its sign w; (0, 0,
// 0, 1) for a corner no triangle at its vertex gives a tangent. `normals`
// may be null or hold zeros (a vertex without: the triangle's face normal
// stands in).
std::vector<glm::vec4> mikktspace_tangents(const glm::vec3* positions, const glm::vec3* normals,
                                           const glm::vec2* texcoords, const uint32_t* indices, size_t triangles);

}  // namespace rayfold::core
