// Axis-aligned bounding boxes for the builders (float, like the nodes they
// become).
#pragma once

#include <algorithm>
#include <limits>

#include <glm/common.hpp>
#include <glm/vec3.hpp>

namespace rayfold::core {

struct Aabb {
  glm::vec3 lo{std::numeric_limits<float>::infinity()};
  glm::vec3 hi{-std::numeric_limits<float>::infinity()};

  bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  void grow(const glm::vec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  void grow(const Aabb& b) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  glm::vec3 centre() const { return (lo + hi) * 0.5f; }
  glm::vec3 extent() const { return hi - lo; }
  // Half the surface area; SAH only ever compares ratios.
  float half_area() const {
    if (empty()) return 0.0f;
    const glm::vec3 e = extent();
    return e.x * e.y + e.y * e.z + e.z * e.x;
  }
};

}  // namespace rayfold::core
