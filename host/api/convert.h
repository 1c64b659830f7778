// Between the public API's plain types (row-major arrays) and the core's GLM
// transforms (column-major).
#pragma once

#include <string>

#include "rayfold/gbuffer.h"
#include "rayfold/types.h"
#include "scene/transform.h"

namespace rayfold::detail {

using core::to_matrix;  // scene/transform.h
using core::to_xform;

// Throws InputError("", what + ...) for a matrix that is not finite or whose
// last row is not 0 0 0 1.
void check_affine(const Matrix4& m, const std::string& what);

}  // namespace rayfold::detail
