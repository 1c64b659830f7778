#include "bvh/wide_bvh.h"

#include <array>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>

#include "util/errors.h"

namespace rayfold::core {
namespace {

bool is_leaf(const rf_node& n) { return (n.meta & RF_NODE_COUNT_MASK) != 0; }

float half_area(const rf_node& n) {
  const float dx = n.bmax[0] - n.bmin[0], dy = n.bmax[1] - n.bmin[1], dz = n.bmax[2] - n.bmin[2];
  return dx * dy + dy * dz + dz * dx;
}

// The collapse that minimises the summed surface area of the binary nodes
// that become wide nodes (a scattered ray's chance of stepping into a node
// goes with its area; every leaf lies in some node's slot whatever the
// collapse, so the leaves' share is the same for all), with at most `width`
// slots a node and every entry a wide node of its own. By dynamic
// programming over the binary tree, children before parents: cost(n, k),
// the least area of the wide nodes at and below n's place in its parent
// when n and what it opens take at most k slots (k = 1: n whole, a wide
// node of its own if it is interior). The choices are made again from the
// children's costs where the nodes are laid out (slots), so only the costs
// are kept. Against opening the largest child first, the 8-wide trees of
// the shared scenes have 26% to 40% fewer nodes and 3% to 11% less summed
// area.
class OptimalCollapse {
 public:
  static constexpr int kMaxWidth = 8;

  OptimalCollapse(const rf_node* nodes, size_t node_count, const std::vector<uint32_t>& entries,
                  const std::vector<bool>& is_entry, int width)
      : nodes_(nodes), is_entry_(is_entry), width_(width), cost_(new Costs[node_count]) {
    RF_CHECK(width >= 2 && width <= kMaxWidth, "wide nodes of 2 to 8 slots");
    // Every node below the entries once, each after both its children (a
    // node is marked when first reached and costed when reached again with
    // its subtree done): entries may lie inside other entries' trees, and a
    // shared subtree is costed on the first path that reaches it.
    std::vector<bool> seen(node_count, false);
    std::vector<std::pair<uint32_t, bool>> stack;  // (node, its children costed)
    for (uint32_t e : entries) stack.emplace_back(e, false);
    while (!stack.empty()) {
      const auto [x, children_done] = stack.back();
      stack.pop_back();
      if (children_done) {
        cost(x, width);
        continue;
      }
      if (seen[x]) continue;
      seen[x] = true;
      stack.emplace_back(x, true);
      if (is_leaf(nodes[x])) continue;
      RF_CHECK(size_t{nodes[x].first} + 1 < node_count,
               "binary node " + std::to_string(x) + "'s children " + std::to_string(nodes[x].first) +
                   " and the next lie outside the " + std::to_string(node_count) + " nodes");
      stack.emplace_back(nodes[x].first, false);
      stack.emplace_back(nodes[x].first + 1, false);
    }
  }

  // The slots of wide node x (interior): its children, opened as planned.
  int slots(uint32_t x, uint32_t* out) const {
    int used = 0, left = 1;
    opened(x, width_, &left);
    place(nodes_[x].first, left, out, used);
    place(nodes_[x].first + 1, width_ - left, out, used);
    return used;
  }

 private:
  using Costs = std::array<float, kMaxWidth>;  // [k - 1]: cost(n, k)

  // The least cost of x's two children in at most k slots, *left of them
  // the first child's (the fewest where several tie: one rule, so that
  // slots() re-makes the constructor's choice).
  float opened(uint32_t x, int k, int* left) const {
    const Costs& l = cost_[nodes_[x].first];
    const Costs& r = cost_[nodes_[x].first + 1];
    float best = INFINITY;
    for (int i = 1; i < k; ++i)
      if (l[i - 1] + r[k - i - 1] < best) {
        best = l[i - 1] + r[k - i - 1];
        *left = i;
      }
    return best;
  }

  // cost(x, 1 .. width), its children's costs already made.
  void cost(uint32_t x, int width) {
    Costs& c = cost_[x];
    if (is_leaf(nodes_[x])) {
      c.fill(0.0f);  // a leaf's share is the same wherever it sits
      return;
    }
    int unused;
    c[0] = half_area(nodes_[x]) + opened(x, width, &unused);
    for (int k = 2; k <= width; ++k) {
      const float o = opened(x, k, &unused);
      c[k - 1] = keeps_whole(x, o) ? c[0] : o;
    }
  }

  // Interior node x stays one slot, its own wide node, rather than opened
  // at cost `open`: an entry always (other walks start there); on a tie too,
  // for the fewer slots and the same decision wherever it is made.
  bool keeps_whole(uint32_t x, float open) const { return is_entry_[x] || !(open < cost_[x][0]); }

  // Node n and what it opens into at most k slots.
  void place(uint32_t n, int k, uint32_t* out, int& used) const {
    int left = 0;
    if (k == 1 || is_leaf(nodes_[n]) || keeps_whole(n, opened(n, k, &left))) {
      out[used++] = n;
      return;
    }
    place(nodes_[n].first, left, out, used);
    place(nodes_[n].first + 1, k - left, out, used);
  }

  const rf_node* nodes_;
  const std::vector<bool>& is_entry_;
  int width_;
  // Per node below an entry, the others unwritten; plain heap memory, given
  // back when the collapse ends (32 bytes a node while it runs).
  std::unique_ptr<Costs[]> cost_;
};

template <class WideNode>
class Collapser {
  static constexpr int kWidth = static_cast<int>(sizeof(WideNode::child) / sizeof(WideNode::child[0]));

 public:
  Collapser(const rf_node* nodes, size_t node_count, const std::vector<uint32_t>& entries, bool optimal)
      : nodes_(nodes), is_entry_(node_count, false) {
    for (uint32_t e : entries) {
      entry_wide_.emplace(e, RF_INVALID);
      is_entry_[e] = true;
    }
    if (optimal) optimal_.emplace(nodes, node_count, entries, is_entry_, kWidth);
    // Each wide node holds the children of an interior binary node of its
    // own, and a binary tree has fewer interior nodes than half its nodes:
    // grown instead, the array was copied into fresh pages at every
    // doubling (a sixth of the conference room's build's page faults). The
    // room reserved and never used (about two thirds) is never touched: it
    // is address space, not resident memory.
    out_.reserve(node_count / 2 + 1);
  }

  // The wide node of interior binary node x's children.
  uint32_t collapse(uint32_t x) {
    const auto entry = is_entry_[x] ? entry_wide_.find(x) : entry_wide_.end();
    if (entry != entry_wide_.end() && entry->second != RF_INVALID) return entry->second;
    const uint32_t w = static_cast<uint32_t>(out_.size());
    out_.emplace_back();
    uint32_t slots[kWidth] = {nodes_[x].first, nodes_[x].first + 1};
    int used = optimal_ ? optimal_->slots(x, slots) : 2;
    while (!optimal_ && used < kWidth) {
      int best = -1;
      float best_area = -1.0f;
      for (int k = 0; k < used; ++k) {
        const rf_node& n = nodes_[slots[k]];
        if (is_leaf(n) || is_entry_[slots[k]]) continue;
        const float a = half_area(n);
        if (a > best_area) {
          best = k;
          best_area = a;
        }
      }
      if (best < 0) break;
      const uint32_t opened = slots[best];
      slots[best] = nodes_[opened].first;
      slots[used++] = nodes_[opened].first + 1;
    }
    WideNode wide;  // every field written below: zeroing it first was a tenth of the collapse
    for (int k = 0; k < kWidth; ++k) {
      if (k >= used) {
        wide.lo_x[k] = wide.lo_y[k] = wide.lo_z[k] = wide.hi_x[k] = wide.hi_y[k] = wide.hi_z[k] = 0.0f;
        wide.child[k] = 0;
        wide.count[k] = RF_INVALID;
        continue;
      }
      const rf_node& n = nodes_[slots[k]];
      wide.lo_x[k] = n.bmin[0];
      wide.lo_y[k] = n.bmin[1];
      wide.lo_z[k] = n.bmin[2];
      wide.hi_x[k] = n.bmax[0];
      wide.hi_y[k] = n.bmax[1];
      wide.hi_z[k] = n.bmax[2];
      wide.count[k] = n.meta & RF_NODE_COUNT_MASK;
      wide.child[k] = is_leaf(n) ? n.first : collapse(slots[k]);
    }
    out_[w] = wide;
    if (entry != entry_wide_.end()) entry->second = w;
    return w;
  }

  PageAlignedVector<WideNode> take() { return std::move(out_); }

 private:
  const rf_node* nodes_;
  std::vector<bool> is_entry_;
  std::unordered_map<uint32_t, uint32_t> entry_wide_;
  std::optional<OptimalCollapse> optimal_;  // unset: the greedy collapse
  PageAlignedVector<WideNode> out_;
};

template <class Trees>
Trees collapse_trees(const rf_node* nodes, size_t node_count, const std::vector<uint32_t>& entries, bool optimal) {
  for (uint32_t e : entries) RF_CHECK_LT(e, node_count, "wide tree entry outside the node array");
  Collapser<typename decltype(Trees::nodes)::value_type> c(nodes, node_count, entries, optimal);
  Trees trees;
  trees.roots.reserve(entries.size());
  for (uint32_t e : entries) {
    trees.roots.push_back(is_leaf(nodes[e]) ? RF_INVALID : c.collapse(e));
  }
  trees.nodes = c.take();
  return trees;
}

// The top-level nodes `tlas` in the bottom level's layout: a leaf's first
// item and count, an interior node's children counted from the top level's
// first node.
std::vector<rf_node> tlas_as_blas(const std::vector<rf_node>& tlas, uint32_t node_base, uint32_t root) {
  RF_CHECK(root >= node_base && root - node_base < tlas.size(), "top-level root outside its nodes");
  std::vector<rf_node> nodes(tlas);
  for (rf_node& n : nodes) {
    const uint32_t count = n.first >> RF_TLAS_COUNT_SHIFT, first = n.first & RF_TLAS_INDEX_MASK;
    n.meta = count;
    n.first = count != 0 || first < node_base ? first : first - node_base;  // below node_base: padding, never read
  }
  return nodes;
}

}  // namespace

WideTrees build_wide_trees(const rf_node* nodes, size_t node_count, const std::vector<uint32_t>& entries) {
  return collapse_trees<WideTrees>(nodes, node_count, entries, false);
}

Wide8Trees build_wide8_trees(const rf_node* nodes, size_t node_count, const std::vector<uint32_t>& entries) {
  return collapse_trees<Wide8Trees>(nodes, node_count, entries, true);
}

Wide8Trees build_wide8_tlas(const std::vector<rf_node>& tlas, uint32_t node_base, uint32_t root) {
  const std::vector<rf_node> nodes = tlas_as_blas(tlas, node_base, root);
  return build_wide8_trees(nodes.data(), nodes.size(), {root - node_base});
}

}  // namespace rayfold::core
