// Build-time tree -> compact rf_node layout.
#pragma once

#include <cstdint>
#include <vector>

#include "bvh/bvh_build.h"
#include "device_layout.h"

namespace rayfold::core {

// Appends `tree` to `out` and returns the root's index (RF_INVALID for an empty
// tree). Node indices are written as index_base + position in `out`; sibling
// pairs land at even indices when index_base is even. Leaf ranges index the
// items laid out in tree.order from item_base on. item_groups, when given,
// holds one group mask per item in tree.order order, and the nodes take the
// top-level layout (kernels/rf_types.h: the leaf count in `first`, the group
// masks in `meta`).
uint32_t flatten_bvh(const BuildTree& tree, uint32_t item_base, const std::vector<uint32_t>* item_groups,
                     uint32_t index_base, std::vector<rf_node>& out);

}  // namespace rayfold::core
