#include "bvh/bvh_flatten.h"

#include <deque>

#include "rf_trace.h"
#include "util/errors.h"

namespace rayfold::core {
namespace {

rf_node make_node(const BuildNode& b) {
  rf_node n{};
  for (int k = 0; k < 3; ++k) {
    n.bmin[k] = b.bounds.lo[k];
    n.bmax[k] = b.bounds.hi[k];
  }
  return n;
}

}  // namespace

uint32_t flatten_bvh(const BuildTree& tree, uint32_t item_base, const std::vector<uint32_t>* item_groups,
                     uint32_t index_base, std::vector<rf_node>& out) {
  if (tree.nodes.empty()) return RF_INVALID;
  RF_CHECK(tree.depth <= RF_STACK_SIZE, "tree deeper than the traversal stack");

  // Group masks bottom-up: children always follow their parent in tree.nodes.
  const bool tlas = item_groups != nullptr;
  std::vector<uint32_t> groups(tree.nodes.size(), 0);
  if (tlas) {
    for (size_t i = tree.nodes.size(); i-- > 0;) {
      const BuildNode& b = tree.nodes[i];
      if (b.is_leaf()) {
        for (uint32_t k = b.first; k < b.first + b.count; ++k) groups[i] |= (*item_groups)[k];
      } else {
        groups[i] = groups[b.left] | groups[b.right];
      }
    }
  }

  const uint32_t root = index_base + static_cast<uint32_t>(out.size());
  out.push_back(make_node(tree.nodes[0]));
  if ((index_base + out.size()) % 2 != 0) out.push_back(rf_node{});  // keeps sibling pairs 64-byte aligned

  std::deque<std::pair<uint32_t, uint32_t>> queue{{0u, root - index_base}};  // (build node, flat position)
  while (!queue.empty()) {
    const auto [bi, fi] = queue.front();
    queue.pop_front();
    const BuildNode& b = tree.nodes[bi];
    if (b.is_leaf()) {
      if (tlas) {
        RF_CHECK(b.count <= RF_TLAS_MAX_LEAF && item_base + b.first <= RF_TLAS_INDEX_MASK,
                 "top-level leaf too large for the node layout");
        out[fi].first = (item_base + b.first) | (b.count << RF_TLAS_COUNT_SHIFT);
        out[fi].meta = groups[bi];
      } else {
        RF_CHECK(b.count <= RF_NODE_COUNT_MASK, "leaf too large for the node layout");
        out[fi].first = item_base + b.first;
        out[fi].meta = b.count;
      }
      continue;
    }
    const uint32_t pair = static_cast<uint32_t>(out.size());
    out.push_back(make_node(tree.nodes[b.left]));
    out.push_back(make_node(tree.nodes[b.right]));
    RF_CHECK(!tlas || index_base + pair <= RF_TLAS_INDEX_MASK, "too many nodes for the top-level node layout");
    out[fi].first = index_base + pair;
    out[fi].meta = groups[bi];
    queue.push_back({b.left, pair});
    queue.push_back({b.right, pair + 1});
  }
  return root;
}

}  // namespace rayfold::core
