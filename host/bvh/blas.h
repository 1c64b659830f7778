// Bottom-level trees: one per mesh, and one per group of static instances
// that share a transform, built once when the scene is loaded and laid out
// together in one flat node array and one triangle array.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "bvh/bvh_build.h"
#include "device_layout.h"
#include "scene/aabb.h"
#include "scene/scene.h"
#include "util/page_aligned.h"

namespace rayfold::core {

// Each tree is stored in its mesh's tree space: object space in units of
// 2^tree_exponents[m] (choose_tree_exponents), so that the mesh's largest
// coordinate lies in [2^-8, 2). Scaling by a power of two is exact, so the
// trees of a scene scaled by 2^k hold the same floats; the scale moves into
// the instance transforms.
struct BlasSet {
  PageAlignedVector<rf_node> nodes;  // all trees (tree space); the TLAS follows them
  PageAlignedVector<rf_tri> tris;    // all trees' triangles in leaf order (tree space)
  // Per mesh; RF_INVALID for a mesh with no triangle, or whose every
  // instance is traced in a merged tree (below).
  std::vector<uint32_t> roots;
  // Static instances with bit-identical world_from_tree (one
  // world_from_object, one tree space) are traced as one instance through
  // one tree built over all their triangles, each triangle's rf_tri::inst
  // giving its member: per-material meshes overlap across a whole building,
  // and a top level over their trees cannot separate them where one tree
  // over their triangles does (random views, docs/results.md: Lost Empire
  // 1.28x to 1.60x of Embree, the car 1.14x to 1.34x, Sponza 1.15x to
  // 1.26x). Per scene instance: the first member of its group (the lowest
  // id), itself for an instance traced through its mesh's own tree.
  std::vector<uint32_t> traced_by;
  // Per scene instance, the tree it is traced through: its mesh's, for the
  // first member of a group the group's; RF_INVALID for the other members
  // (their triangles are in the first member's tree) and for an instance
  // whose tree holds no triangle.
  std::vector<uint32_t> instance_roots;
  std::vector<uint8_t> merged;      // per scene instance: 1 when traced in a merged tree
  std::vector<Aabb> bounds;         // per mesh, object space
  std::vector<int> tree_exponents;  // per mesh: tree space = object space * 2^-e
  // Triangles of nonzero extent under 2^-60 in tree space: the watertight
  // test's edge functions, products of two such extents, fall below the
  // normal floats and cannot resolve them.
  size_t unresolvable_triangles = 0;
  double build_ms = 0.0;  // with the wide trees prepare_scene adds (bvh/scene_data.h)
  double sah_cost = 0.0;  // per tree SAH cost, weighted by triangle count
  int max_depth = 0;
};

// Which instances may be merged (BlasSet::traced_by). Dynamic instances are
// not: a merged tree moves only as a whole.
struct MergeOptions {
  bool enabled = true;
  // Per scene instance, nonzero: it moves after the build (an animation, a
  // set_transform) and keeps its mesh's tree. Shorter than the instance
  // list: the rest are static.
  std::vector<uint8_t> dynamic;
};

// Builds the trees in parallel on `threads` threads (0: all cores).
// `beside_fill`, if set, is called with the set once everything but its
// triangles is done, on the calling thread while the others fill them
// (it must not read `tris`): serial work that needs the nodes, beside the
// fill.
BlasSet build_blas_set(const Scene& scene, const BuildOptions& options = {}, unsigned threads = 0,
                       const MergeOptions& merge = {}, const std::function<void(const BlasSet&)>& beside_fill = {});

// The power of two that brings a box's largest coordinate magnitude into
// [1, 2): floor(log2(max |coordinate|)), 0 for an empty or all-zero box.
int scale_exponent(const Aabb& box);

// Each mesh's tree exponent from its object-space bounds: the scene's
// largest scale_exponent for every mesh within 2^8 of it, its own for the
// smaller ones (whose triangles would otherwise lose normal-float range).
// Meshes placed in one space give their instances one linear tree_from_trace
// where their nodes' transforms agree, so the tile kernel sets their rays up
// once (kernels/rf_tile.h): per-mesh scales made the Dabrovic Sponza's
// meshes, in three, set up 10 times a tile. Depends only on the bounds'
// exponents' differences, so a scene scaled by 2^k keeps its trees.
void choose_tree_exponents(const std::vector<Aabb>& bounds, std::vector<int>& exponents);

// object_from_tree of a mesh: the uniform scale 2^tree_exponent.
Xform object_from_tree(const BlasSet& blas, uint32_t mesh);

}  // namespace rayfold::core
