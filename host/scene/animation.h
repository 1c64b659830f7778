// Deterministic motion for dynamic scenes (`--animate`): a fixed subset of
// instances turns about the vertical axis through its centre and bobs up and
// down, so every frame needs culling and a new top-level tree while the
// bottom-level trees stay as built.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "scene/scene.h"

namespace rayfold::core {

// Every fourth instance moves.
inline bool is_animated(size_t instance) { return instance % 4 == 1; }

// is_animated for each of `count` instances, as MergeOptions::dynamic takes it.
inline std::vector<uint8_t> animated_instances(size_t count) {
  std::vector<uint8_t> out(count);
  for (size_t i = 0; i < count; ++i) out[i] = is_animated(i);
  return out;
}

// The instance's world_from_object at a frame (frame 0 is the file's pose).
Xform animated_world_from_object(const Instance& instance, const Aabb& object_bounds, size_t index, int frame);

}  // namespace rayfold::core
