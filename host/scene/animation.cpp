#include "scene/animation.h"

#include <cmath>

#include <glm/gtc/matrix_transform.hpp>

namespace rayfold::core {

Xform animated_world_from_object(const Instance& instance, const Aabb& object_bounds, size_t index, int frame) {
  const Aabb world = transform_bounds_conservative(instance.world_from_object, object_bounds);
  if (world.empty() || frame == 0) return instance.world_from_object;
  const glm::dvec3 centre(world.centre());
  const double size = glm::length(glm::dvec3(world.extent()));
  const double phase = 0.7 * static_cast<double>(index);
  const double angle = 0.05 * frame;  // radians per frame
  const double lift = 0.1 * size * std::sin(0.3 * frame + phase);
  Xform m = glm::translate(Xform(1.0), centre + glm::dvec3(0.0, lift, 0.0));
  m = glm::rotate(m, angle, glm::dvec3(0.0, 1.0, 0.0));
  m = glm::translate(m, -centre);
  return m * instance.world_from_object;
}

}  // namespace rayfold::core
