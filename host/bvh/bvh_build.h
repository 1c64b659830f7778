// Binned SAH BVH construction over primitive boxes: the build-time tree.
// The same builder serves the bottom level (triangles) and the top level
// (instances); host/bvh/bvh_flatten.h turns its result into rf_node arrays.
#pragma once

#include <cstdint>
#include <vector>

#include "scene/aabb.h"
#include "util/page_aligned.h"

namespace rayfold::core {

struct BuildNode {
  Aabb bounds;
  uint32_t left = 0, right = 0;   // child node indices (interior)
  uint32_t first = 0, count = 0;  // range in BuildTree::order (leaf, count > 0)
  bool is_leaf() const { return count > 0; }
};

struct BuildOptions {
  int bins = 16;  // nodes of at most 32 records: at most 8 (bvh_build.cpp, kFewBins)
  uint32_t max_leaf_size = 8;
  // Nodes of at most this many records (up to 16; a record is a primitive
  // or a pair, below) are split at the best of every boundary between them
  // ordered by centre (ties by first primitive index) on each axis; larger
  // ones at the best bin boundary.
  uint32_t sweep_size = 4;
  float traversal_cost = 1.0f;     // SAH cost of one box-pair test
  float intersection_cost = 1.0f;  // SAH cost of one primitive test
  // Meshes of at least dense_triangles triangles (build_blas_set) are built
  // with dense_intersection_cost instead: seen whole, such a mesh has about
  // a triangle per pixel or fewer, the rays of one lane group part ways in
  // its last levels, and fewer, fuller leaves are what the tile kernel
  // traces fastest. On random views (docs/results.md) 0.3 took the dragon
  // (871k triangles) from 0.90x to 1.05x-1.09x of Embree and the
  // armadillo (346k) 3% to 5% faster; on Lost Empire and Sponza, whose
  // meshes hold large triangles, it was 10% to 20% slower, and their
  // meshes (67k and 10k triangles at most) keep 1.0. A merged tree
  // (bvh/blas.h) counts its largest member: a building merged from meshes
  // of large triangles is no denser for it (on Lost Empire, merged into
  // one tree of 225k, 0.3 traced 5% slower, on the conference room 12%).
  size_t dense_triangles = size_t{1} << 17;
  float dense_intersection_cost = 0.3f;
  // Neighbouring primitives whose boxes are alike (the two halves of a
  // quad, neighbours in a mesh's triangle order), paired greedily in index
  // order, are binned as one record and share a leaf; the SAH and
  // max_leaf_size count them as two (with a max_leaf_size of 1 nothing
  // pairs). Where most pair, the build moves far fewer records: Lost
  // Empire's build took 0.70x the time, the conference room's 0.71x, the
  // car's 0.77x (with a fix to the records pass), with the tile kernel's
  // counters on random views within 3% (docs/results.md).
  bool pair_primitives = true;
  // Past this depth splits become object medians, so that trees of up to
  // 2^24 primitives stay within the device's 64-entry traversal stack.
  int median_depth = 36;
};

struct BuildTree {
  PageAlignedVector<BuildNode> nodes;  // nodes[0] is the root; empty for no input (large: util/large_pages.h)
  std::vector<uint32_t> order;   // primitive indices in leaf order
  int depth = 0;                 // levels, root = 1
  double sah_cost = 0.0;         // expected cost per ray through the root
};

// Primitives with empty boxes are dropped (they can never be hit). The tree
// (every node's box and primitives, the leaf order) is the same for every
// thread count (0: all cores).
BuildTree build_sah(const Aabb* prim_bounds, size_t count, const BuildOptions& options = {}, unsigned threads = 1);
inline BuildTree build_sah(const std::vector<Aabb>& prim_bounds, const BuildOptions& options = {}, unsigned threads = 1) {
  return build_sah(prim_bounds.data(), prim_bounds.size(), options, threads);
}

}  // namespace rayfold::core
