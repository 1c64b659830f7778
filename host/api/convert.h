// Between the public API's plain types (row-major arrays) and the core's GLM
// transforms (column-major).
#pragma once

#include <string>

#include "rayfold/gbuffer.h"
#include "rayfold/types.h"
#include "scene/transform.h"

namespace rayfold::detail {

inline core::Xform to_xform(const Matrix4& m) {
  core::Xform x;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) x[c][r] = m[4 * r + c];
  return x;
}

inline Matrix4 to_matrix(const core::Xform& x) {
  Matrix4 m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m[4 * r + c] = x[c][r];
  return m;
}

// Throws InputError("", what + ...) for a matrix that is not finite or whose
// last row is not 0 0 0 1.
void check_affine(const Matrix4& m, const std::string& what);

}  // namespace rayfold::detail
