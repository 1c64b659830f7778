#include "scene/transform.h"

#include <algorithm>
#include <cmath>

#include <glm/gtc/matrix_inverse.hpp>
#include <glm/mat3x3.hpp>

namespace rayfold::core {

double linear_determinant(const Xform& m) { return glm::determinant(glm::dmat3(m)); }

bool affine_inverse(const Xform& m, Xform* inverse) {
  const double det = linear_determinant(m);
  if (!std::isfinite(det) || det == 0.0) return false;
  *inverse = glm::affineInverse(m);
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      if (!std::isfinite((*inverse)[c][r])) return false;
  return true;
}

void to_rows3x4(const Xform& m, float out[12]) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) out[4 * r + c] = static_cast<float>(m[c][r]);
}

void normal_matrix_rows3x3(const Xform& m, float out[9]) {
  const glm::dmat3 n = glm::inverseTranspose(glm::dmat3(m));
  // Normals are normalised after the product, so any positive scale gives
  // the same direction; a power of two that brings the largest entry to
  // [1, 2) keeps the product inside the float range and makes the matrix
  // the same for a transform scaled by any power of two.
  double big = 0.0;
  for (int c = 0; c < 3; ++c)
    for (int r = 0; r < 3; ++r) big = std::max(big, std::fabs(n[c][r]));
  const int e = big > 0.0 && std::isfinite(big) ? std::ilogb(big) : 0;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out[3 * r + c] = static_cast<float>(std::ldexp(n[c][r], -e));
}

Xform uniform_scale(int exponent) {
  const double s = std::ldexp(1.0, exponent);
  return Xform(glm::dvec4(s, 0.0, 0.0, 0.0), glm::dvec4(0.0, s, 0.0, 0.0), glm::dvec4(0.0, 0.0, s, 0.0),
               glm::dvec4(0.0, 0.0, 0.0, 1.0));
}

glm::dvec3 transform_point(const Xform& m, const glm::dvec3& p) { return glm::dvec3(m * glm::dvec4(p, 1.0)); }

Aabb transform_bounds_conservative(const Xform& m, const Aabb& b, double extra_pad) {
  Aabb out;
  if (b.empty()) return out;
  glm::dvec3 lo(INFINITY), hi(-INFINITY);
  for (int i = 0; i < 8; ++i) {
    const glm::dvec3 p((i & 1) ? b.hi.x : b.lo.x, (i & 2) ? b.hi.y : b.lo.y, (i & 4) ? b.hi.z : b.lo.z);
    const glm::dvec3 q = transform_point(m, p);
    lo = glm::min(lo, q);
    hi = glm::max(hi, q);
  }
  // The device transforms rays, not boxes, in float; the pad absorbs the
  // difference between that float image and this double one.
  const glm::dvec3 size = hi - lo;
  const double scale = std::max({size.x, size.y, size.z, std::fabs(lo.x), std::fabs(lo.y), std::fabs(lo.z),
                                 std::fabs(hi.x), std::fabs(hi.y), std::fabs(hi.z)});
  const double pad = scale * 0x1p-20 + extra_pad;
  for (int k = 0; k < 3; ++k) {
    out.lo[k] = std::nextafter(static_cast<float>(lo[k] - pad), -INFINITY);
    out.hi[k] = std::nextafter(static_cast<float>(hi[k] + pad), INFINITY);
  }
  return out;
}

}  // namespace rayfold::core
