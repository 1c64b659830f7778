// The ground truth for accuracy: every pixel's primary ray in double
// precision from the exact pinhole model (not the float rays the tracers
// use), through the same trees, with the watertight triangle test evaluated
// in double. What the float tracers are measured against (accuracy.h).
#pragma once

#include <cstdint>
#include <vector>

#include "fold/frame.h"
#include "scene/camera.h"
#include "scene/scene.h"

namespace rayfold::core {

struct ReferenceHit {
  double distance = INFINITY;  // from the eye along the normalised ray
  uint32_t instance = RF_INVALID;
  uint32_t primitive = RF_INVALID;
};

// width * height hits, row-major. threads = 0: all cores. brute_force
// tests every triangle of every instance (no culling, no box tests): the
// check that the trees lose nothing, for small scenes.
std::vector<ReferenceHit> trace_double_reference(const Scene& scene, const SceneData& data, const Camera& camera,
                                                 unsigned threads = 0, bool brute_force = false);

}  // namespace rayfold::core
