#include "bvh/bvh_flatten.h"

#include <algorithm>

#include "rf_trace.h"
#include "util/errors.h"
#include "util/parallel.h"

namespace rayfold::core {
namespace {

// Flat position of build node i past the root, given the first pair's.
// build_sah appends children in pairs after their parent, so every pair
// starts at an odd build index and lands at an even flat one.
inline uint32_t flat_of(uint32_t i, uint32_t first_pair) { return first_pair + (i - 1); }

}  // namespace

size_t flat_node_count(const BuildTree& tree, uint32_t position) {
  if (tree.nodes.empty()) return 0;
  return tree.nodes.size() + ((position + 1) % 2 != 0 ? 1 : 0);
}

uint32_t flatten_bvh_at(const BuildTree& tree, uint32_t item_base, const std::vector<uint32_t>* item_groups,
                        uint32_t position, rf_node* dst, unsigned threads) {
  if (tree.nodes.empty()) return RF_INVALID;
  RF_CHECK_LE(tree.depth, RF_STACK_SIZE, "tree deeper than the traversal stack");

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
  const size_t count = flat_node_count(tree, position);
  const uint32_t first_pair = position + static_cast<uint32_t>(count - tree.nodes.size()) + 1;
  RF_CHECK(!tlas || position + count <= RF_TLAS_INDEX_MASK, "too many nodes for the top-level node layout");
  if (count > tree.nodes.size()) dst[1] = rf_node{};  // keeps sibling pairs 64-byte aligned

  // The build's order is kept (each pair where its parent was split, so a
  // subtree's nodes lie together), which makes this one pass over the nodes.
  parallel_for(tree.nodes.size(), threads, size_t{1} << 14, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const BuildNode& b = tree.nodes[i];
      rf_node& n = dst[i == 0 ? 0 : flat_of(static_cast<uint32_t>(i), first_pair) - position];
      n = rf_node{};
      for (int k = 0; k < 3; ++k) {
        n.bmin[k] = b.bounds.lo[k];
        n.bmax[k] = b.bounds.hi[k];
      }
      if (b.is_leaf()) {
        if (tlas) {
          RF_CHECK(b.count <= RF_TLAS_MAX_LEAF && item_base + b.first <= RF_TLAS_INDEX_MASK,
                   "top-level leaf too large for the node layout");
          n.first = (item_base + b.first) | (b.count << RF_TLAS_COUNT_SHIFT);
          n.meta = groups[i];
        } else {
          RF_CHECK_LE(b.count, RF_NODE_COUNT_MASK, "leaf too large for the node layout");
          n.first = item_base + b.first;
          n.meta = b.count;
        }
      } else {
        RF_CHECK(b.right == b.left + 1 && b.left % 2 == 1, "build nodes not in sibling pairs");
        n.first = flat_of(b.left, first_pair);
        n.meta = tlas ? groups[i] : 0;
      }
    }
  });
  return position;
}

uint32_t flatten_bvh(const BuildTree& tree, uint32_t item_base, const std::vector<uint32_t>* item_groups,
                     uint32_t index_base, std::vector<rf_node>& out) {
  const size_t at = out.size();
  const uint32_t position = index_base + static_cast<uint32_t>(at);
  const size_t count = flat_node_count(tree, position);
  if (count == 0) return RF_INVALID;
  const size_t needed = at + count;
  if (out.capacity() < needed) out.reserve(std::max(needed, 2 * out.capacity()));  // geometric over many calls
  out.resize(needed);
  return flatten_bvh_at(tree, item_base, item_groups, position, out.data() + at, 1);
}

}  // namespace rayfold::core
