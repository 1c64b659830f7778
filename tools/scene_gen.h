// The deterministic generator of rayfold's own test and demo scenes: an
// atrium-like interior (floor, walls, galleries, rows of columns and arches,
// furniture-like clutter of very different sizes). The same options always
// give the same scene, bit for bit.
#pragma once

#include <cstddef>
#include <cstdint>

#include "scene/scene.h"

namespace rayfold::core {

struct GenOptions {
  uint64_t seed = 1;
  int objects = 240;                // instances in the scene (at least 1)
  size_t triangle_budget = 150000;  // rendered triangles, approached from below
};

Scene generate_atrium(const GenOptions& options);

}  // namespace rayfold::core
