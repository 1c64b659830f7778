#include "bvh/bvh_build.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

#include "util/errors.h"

namespace rayfold::core {
namespace {

struct Bin {
  Aabb bounds;
  uint32_t count = 0;
};

struct Task {
  uint32_t node;
  int depth;
};

struct Split {
  int axis = -1;
  int bin = 0;  // primitives in bins [0, bin] go left
  float cost = 0.0f;
};

class Builder {
 public:
  Builder(const std::vector<Aabb>& bounds, const BuildOptions& opt) : bounds_(bounds), opt_(opt) {
    centres_.resize(bounds.size());
    for (size_t i = 0; i < bounds.size(); ++i) centres_[i] = bounds[i].centre();
  }

  BuildTree run() {
    BuildTree tree;
    for (uint32_t i = 0; i < bounds_.size(); ++i)
      if (!bounds_[i].empty()) tree.order.push_back(i);
    if (tree.order.empty()) return tree;
    order_ = &tree.order;
    nodes_ = &tree.nodes;
    BuildNode root;
    root.first = 0;
    root.count = static_cast<uint32_t>(tree.order.size());
    tree.nodes.push_back(root);
    std::vector<Task> stack{{0, 1}};
    while (!stack.empty()) {
      const Task task = stack.back();
      stack.pop_back();
      tree.depth = std::max(tree.depth, task.depth);
      if (subdivide(task.node, task.depth)) {
        const BuildNode& n = tree.nodes[task.node];
        stack.push_back({n.right, task.depth + 1});
        stack.push_back({n.left, task.depth + 1});
      }
    }
    tree.sah_cost = sah_cost(tree);
    return tree;
  }

 private:
  // Fills the node's bounds and splits it in two; false when it stays a leaf.
  bool subdivide(uint32_t ni, int depth) {
    BuildNode& node = (*nodes_)[ni];
    Aabb centre_bounds;
    for (uint32_t i = node.first; i < node.first + node.count; ++i) {
      node.bounds.grow(bounds_[(*order_)[i]]);
      centre_bounds.grow(centres_[(*order_)[i]]);
    }
    if (node.count <= 1) return false;
    const uint32_t first = node.first, count = node.count;
    uint32_t mid = first;
    if (depth >= opt_.median_depth) {
      if (count <= opt_.max_leaf_size) return false;
    } else {
      const Split split = find_split(first, count, centre_bounds, node.bounds);
      const float leaf_cost = opt_.intersection_cost * static_cast<float>(count);
      const bool sah_prefers_leaf = split.axis < 0 || split.cost >= leaf_cost;
      if (sah_prefers_leaf && count <= opt_.max_leaf_size) return false;
      if (split.axis >= 0) {
        const float lo = centre_bounds.lo[split.axis];
        const float scale = opt_.bins / (centre_bounds.hi[split.axis] - lo);
        auto goes_left = [&](uint32_t p) { return bin_of(centres_[p][split.axis], lo, scale) <= split.bin; };
        mid = static_cast<uint32_t>(
            std::partition(order_->begin() + first, order_->begin() + first + count, goes_left) - order_->begin());
      }
    }
    if (mid == first || mid == first + count) {
      // No useful SAH split (all centres alike, or too deep): split at the
      // object median of the widest centre axis, which always terminates.
      const glm::vec3 e = centre_bounds.extent();
      const int axis = (e.x >= e.y && e.x >= e.z) ? 0 : (e.y >= e.z ? 1 : 2);
      mid = first + count / 2;
      std::nth_element(order_->begin() + first, order_->begin() + mid, order_->begin() + first + count,
                       [&](uint32_t a, uint32_t b) {
                         if (centres_[a][axis] != centres_[b][axis]) return centres_[a][axis] < centres_[b][axis];
                         return a < b;
                       });
    }
    BuildNode left, right;
    left.first = first;
    left.count = mid - first;
    right.first = mid;
    right.count = first + count - mid;
    const uint32_t li = static_cast<uint32_t>(nodes_->size());
    nodes_->push_back(left);
    nodes_->push_back(right);
    BuildNode& parent = (*nodes_)[ni];  // push_back may have moved it
    parent.left = li;
    parent.right = li + 1;
    parent.count = 0;
    return true;
  }

  // Clamped in float first: a tiny centre extent makes scale huge, and a
  // float-to-int conversion of an out-of-range value is undefined.
  int bin_of(float c, float lo, float scale) const {
    const float f = (c - lo) * scale;
    if (!(f > 0.0f)) return 0;
    if (f >= static_cast<float>(opt_.bins - 1)) return opt_.bins - 1;
    return static_cast<int>(f);
  }

  // One pass over the primitives bins all three axes (the build's hot loop);
  // the sweep then prices every bin boundary of every axis.
  Split find_split(uint32_t first, uint32_t count, const Aabb& centre_bounds, const Aabb& node_bounds) const {
    Split best;
    best.cost = INFINITY;
    constexpr int kMaxBins = 64;
    RF_CHECK(opt_.bins >= 2 && opt_.bins <= kMaxBins, "bin count out of range");
    const float parent_area = node_bounds.half_area();
    bool splittable[3];
    float lo[3], scale[3];
    for (int axis = 0; axis < 3; ++axis) {
      lo[axis] = centre_bounds.lo[axis];
      splittable[axis] = centre_bounds.hi[axis] > lo[axis];
      scale[axis] = splittable[axis] ? opt_.bins / (centre_bounds.hi[axis] - lo[axis]) : 0.0f;
    }
    // Only the bins in use are reset: resetting all 3 x 64 cost more than
    // the binning itself on the many small nodes near the leaves.
    std::array<std::array<Bin, kMaxBins>, 3> bins;
    for (int axis = 0; axis < 3; ++axis)
      for (int i = 0; i < opt_.bins; ++i) bins[axis][i] = Bin();
    for (uint32_t i = first; i < first + count; ++i) {
      const uint32_t p = (*order_)[i];
      const Aabb& box = bounds_[p];
      const glm::vec3& c = centres_[p];
      for (int axis = 0; axis < 3; ++axis) {
        Bin& b = bins[axis][bin_of(c[axis], lo[axis], scale[axis])];
        b.bounds.grow(box);
        b.count++;
      }
    }
    for (int axis = 0; axis < 3; ++axis) {
      if (!splittable[axis]) continue;
      // Sweep from the right to know each right side's area and count.
      std::array<float, kMaxBins> right_area;
      std::array<uint32_t, kMaxBins> right_count;
      Aabb acc;
      uint32_t n = 0;
      for (int i = opt_.bins - 1; i > 0; --i) {
        acc.grow(bins[axis][i].bounds);
        n += bins[axis][i].count;
        right_area[i] = acc.half_area();
        right_count[i] = n;
      }
      acc = Aabb();
      n = 0;
      for (int i = 0; i < opt_.bins - 1; ++i) {
        acc.grow(bins[axis][i].bounds);
        n += bins[axis][i].count;
        if (n == 0 || right_count[i + 1] == 0) continue;
        const float cost = opt_.traversal_cost + opt_.intersection_cost *
                                                     (acc.half_area() * n + right_area[i + 1] * right_count[i + 1]) /
                                                     std::max(parent_area, 1e-30f);
        if (cost < best.cost) {
          best.cost = cost;
          best.axis = axis;
          best.bin = i;
        }
      }
    }
    return best;
  }

  double sah_cost(const BuildTree& tree) const {
    const double root_area = std::max<double>(tree.nodes[0].bounds.half_area(), 1e-300);
    double cost = 0.0;
    for (const BuildNode& n : tree.nodes) {
      const double a = n.bounds.half_area() / root_area;
      cost += n.is_leaf() ? a * opt_.intersection_cost * n.count : a * opt_.traversal_cost;
    }
    return cost;
  }

  const std::vector<Aabb>& bounds_;
  const BuildOptions& opt_;
  std::vector<glm::vec3> centres_;
  std::vector<uint32_t>* order_ = nullptr;
  std::vector<BuildNode>* nodes_ = nullptr;
};

}  // namespace

BuildTree build_sah(const std::vector<Aabb>& prim_bounds, const BuildOptions& options) {
  return Builder(prim_bounds, options).run();
}

}  // namespace rayfold::core
