// Affine transforms on the host, in double, named destination_from_source
// (pbrt-v4). They are rounded to float once, when written into the device
// layout, so every consumer of a matrix sees the same floats.
#pragma once

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include "rayfold/types.h"
#include "scene/aabb.h"

namespace rayfold::core {

using Xform = glm::dmat4;  // column-major; the last row is (0, 0, 0, 1)

// Determinant of the linear part: its sign is the handedness (negative for a
// mirror), its zero a singular transform.
double linear_determinant(const Xform& m);

// Inverse of an affine transform; false when it is singular or not finite.
bool affine_inverse(const Xform& m, Xform* inverse);

// Row-major 3x4 float layout of rf_instance::tree_from_trace.
void to_rows3x4(const Xform& m, float out[12]);

// Row-major 3x3 float matrix that takes object-space normals to the
// destination space: the inverse transpose of the linear part of m, scaled by
// the power of two that brings its largest entry into [1, 2) (a normal's
// direction is all that counts).
void normal_matrix_rows3x3(const Xform& m, float out[9]);

// The uniform scale by 2^exponent (exact in double).
Xform uniform_scale(int exponent);

glm::dvec3 transform_point(const Xform& m, const glm::dvec3& p);

// Between the public row-major rayfold::Matrix4 and the column-major Xform,
// value for value.
inline Xform to_xform(const rayfold::Matrix4& m) {
  Xform x;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) x[c][r] = m[4 * r + c];
  return x;
}

inline rayfold::Matrix4 to_matrix(const Xform& x) {
  rayfold::Matrix4 m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m[4 * r + c] = x[c][r];
  return m;
}

// Bounds of a float box under an affine transform, rounded outwards and padded
// by a relative 2^-20 of the box's size and position plus `extra_pad`, so the
// result contains the float image of every point in the box whatever the
// rounding.
Aabb transform_bounds_conservative(const Xform& m, const Aabb& b, double extra_pad = 0.0);

}  // namespace rayfold::core
