// Bottom-level trees: one per mesh, built once when the scene is loaded and
// laid out together in one flat node array and one triangle array.
#pragma once

#include <cstdint>
#include <vector>

#include "aabb.h"
#include "bvh_build.h"
#include "device_layout.h"
#include "scene.h"

namespace rayfold {

struct BlasSet {
  std::vector<rf_node> nodes;   // all meshes' trees; the TLAS follows them
  std::vector<rf_tri> tris;     // all meshes' triangles in leaf order
  std::vector<uint32_t> roots;  // per mesh; RF_INVALID for a mesh with no triangle
  std::vector<Aabb> bounds;     // per mesh, object space
  double build_ms = 0.0;
  double sah_cost = 0.0;        // per mesh SAH cost, weighted by triangle count
  int max_depth = 0;
};

// Builds the meshes' trees in parallel on `threads` threads (0: all cores).
BlasSet build_blas_set(const Scene& scene, const BuildOptions& options = {}, unsigned threads = 0);

}  // namespace rayfold
