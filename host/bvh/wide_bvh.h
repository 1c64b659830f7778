// Wide trees collapsed from the binary ones: 4-wide (kernels/rf_types.h,
// rf_wide_node), the bottom levels of the tile kernel; 8-wide
// (rf_wide8_node), the bottom levels and top level of the single-ray query
// kernel (rays/ray_queries.h).
//
// Why wide: the tile kernel pays a fixed cost per node it pops (its stack,
// the children's loads, the narrowing of the tile's lane groups), and on a
// dense mesh it pops three nodes for every leaf it enters. A wide node holds
// four children, so a pop decides four boxes. A scattered ray's walk is
// bound by its steps too, and one AVX vector decides eight boxes. Why
// collapsed from the binary tree rather than built anew: a lane of the tile,
// or a single ray, takes hits only from the leaves its own slab test enters,
// so with the binary tree's leaves, boxes and triangle ranges the kernels
// find exactly the CPU reference's hits, whatever the nodes above the
// leaves.
#pragma once

#include <cstdint>
#include <vector>

#include "device_layout.h"
#include "util/page_aligned.h"

namespace rayfold::core {

struct WideTrees {
  PageAlignedVector<rf_wide_node> nodes;
  // Per entry node given to build_wide_trees: the wide node holding its
  // children, RF_INVALID for a leaf entry.
  std::vector<uint32_t> roots;
};

// Collapses the binary trees below `entries` (indices into `nodes`: every
// node a traversal starts from, each instance's re-braided cut) into wide
// nodes. Each wide node takes its binary node's children and opens the
// largest interior one (by surface area) until it holds four; an entry is
// never opened into its parent, so that it keeps a wide node of its own.
// A subtree shared by several entries is collapsed once.
WideTrees build_wide_trees(const rf_node* nodes, size_t node_count, const std::vector<uint32_t>& entries);

// The same into 8-wide nodes, which binary nodes become wide ones chosen
// to minimise their summed surface area (a scattered ray's expected steps;
// wide_bvh.cpp, OptimalCollapse) rather than by opening the largest child:
// the shared scenes' trees have 26% to 40% fewer nodes, and 1M scattered
// rays trace 1.01x to 1.05x faster. Each entry keeps a wide node of its own.
struct Wide8Trees {
  PageAlignedVector<rf_wide8_node> nodes;
  std::vector<uint32_t> roots;
};
Wide8Trees build_wide8_trees(const rf_node* nodes, size_t node_count, const std::vector<uint32_t>& entries);

// A query frame's top level as 8-wide nodes, for the single-ray query
// kernel (kernels/rf_trace.h, rf_trace_query_tlas_wide): the top-level
// nodes `tlas` (rf_node's top-level layout) placed at node_base, rooted at
// `root`, collapsed as a bottom-level tree; a leaf child's `child` is its
// first instance and `count` their number. roots[0]: the 8-wide node of the
// root's children, RF_INVALID when the root is a leaf.
Wide8Trees build_wide8_tlas(const std::vector<rf_node>& tlas, uint32_t node_base, uint32_t root);

}  // namespace rayfold::core
