// Build-time tree -> compact rf_node layout.
#pragma once

#include <cstdint>
#include <vector>

#include "bvh/bvh_build.h"
#include "device_layout.h"

namespace rayfold::core {

// Appends `tree` to `out` and returns the root's index (RF_INVALID for an empty
// tree). The nodes keep the build's order (each sibling pair where its parent
// was split, so a subtree lies together). Node indices are written as
// index_base + position in `out`; sibling pairs land at even indices. Leaf ranges index the
// items laid out in tree.order from item_base on. item_groups, when given,
// holds one group mask per item in tree.order order, and the nodes take the
// top-level layout (kernels/rf_types.h: the leaf count in `first`, the group
// masks in `meta`).
uint32_t flatten_bvh(const BuildTree& tree, uint32_t item_base, const std::vector<uint32_t>* item_groups,
                     uint32_t index_base, std::vector<rf_node>& out);

// The nodes flatten_bvh writes for `tree` with its root at node index
// `position` (the tree's nodes, and one pad where the first pair would start
// at an odd index).
size_t flat_node_count(const BuildTree& tree, uint32_t position);

// flatten_bvh into dst[0, flat_node_count(tree, position)) for a root at node
// index `position`, on `threads` threads; returns `position`.
uint32_t flatten_bvh_at(const BuildTree& tree, uint32_t item_base, const std::vector<uint32_t>* item_groups,
                        uint32_t position, rf_node* dst, unsigned threads);

}  // namespace rayfold::core
