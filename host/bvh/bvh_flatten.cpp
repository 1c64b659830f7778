#include "bvh/bvh_flatten.h"

#include <algorithm>


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
  std::vector<uint32_t> groups(tlas ? tree.nodes.size() : 0, 0);
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

  const size_t needed = out.size() + tree.nodes.size() + 1;
  if (out.capacity() < needed) out.reserve(std::max(needed, 2 * out.capacity()));  // geometric over many calls
  const uint32_t root = index_base + static_cast<uint32_t>(out.size());
  out.push_back(make_node(tree.nodes[0]));
  if ((index_base + out.size()) % 2 != 0) out.push_back(rf_node{});  // keeps sibling pairs 64-byte aligned

  // Breadth first: (build node, flat position) pairs, consumed in order.
  std::vector<std::pair<uint32_t, uint32_t>> queue;
  queue.reserve(tree.nodes.size());
  queue.push_back({0u, root - index_base});
  for (size_t head = 0; head < queue.size(); ++head) {
    const auto [bi, fi] = queue[head];
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
    out[fi].meta = tlas ? groups[bi] : 0;
    queue.push_back({b.left, pair});
    queue.push_back({b.right, pair + 1});
  }
  return root;
}

}  // namespace rayfold::core
