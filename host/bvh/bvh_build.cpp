#include "bvh/bvh_build.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "util/errors.h"
#include "util/large_pages.h"
#include "util/parallel.h"

namespace rayfold::core {
namespace {

// Four floats in one SSE or NEON register (GCC and Clang vector extensions):
// x, y, z and a spare lane. Min, max, add and multiply of these are the same
// IEEE operations as the scalar ones, lane by lane.
typedef float v4f __attribute__((vector_size(16)));
typedef int32_t v4i __attribute__((vector_size(16)));

inline v4f vmin(v4f a, v4f b) { return b < a ? b : a; }
inline v4f vmax(v4f a, v4f b) { return a < b ? b : a; }

// One record as the builder moves it: the box of one primitive, or of two
// with consecutive indices (BuildOptions::pair_primitives), and in the spare
// lane of lo its first index times 2, plus 1 for a pair. Partitioning these
// 32-byte records in place keeps every pass over a node a sequential read
// (an index array into the boxes made the deep levels cache misses). The
// spare lane's bits read as a float are a denormal, a NaN or any other
// value, and arithmetic on denormals is slow: every use of the box goes
// through box_lo(), which clears that lane.
struct PrimRef {
  v4f lo, hi;  // hi's spare lane is 0
  uint32_t key() const {
    uint32_t k;
    std::memcpy(&k, reinterpret_cast<const char*>(&lo) + 12, 4);
    return k;
  }
  uint32_t index() const { return key() >> 1; }
  // The primitives it holds: 1, or 2 for a pair.
  uint32_t weight() const { return (key() & 1u) + 1u; }
  v4f box_lo() const {
    const v4i mask = {-1, -1, -1, 0};
    return reinterpret_cast<v4f>(reinterpret_cast<v4i>(lo) & mask);
  }
  // (lo + hi) * 0.5 as Aabb::centre() computes it.
  v4f centre() const { return (box_lo() + hi) * 0.5f; }
};

struct Box4 {
  v4f lo = {INFINITY, INFINITY, INFINITY, INFINITY};
  v4f hi = {-INFINITY, -INFINITY, -INFINITY, -INFINITY};
  void grow(v4f l, v4f h) {
    lo = vmin(lo, l);
    hi = vmax(hi, h);
  }
  void grow(const Box4& b) { grow(b.lo, b.hi); }
  // Aabb::half_area of a box that is not empty.
  float half_area() const {
    const v4f e = hi - lo;
    return e[0] * e[1] + e[1] * e[2] + e[2] * e[0];
  }
  Aabb aabb() const {
    Aabb a;
    for (int k = 0; k < 3; ++k) {
      a.lo[k] = lo[k];
      a.hi[k] = hi[k];
    }
    return a;
  }
};

constexpr int kMaxBins = 64;

// The most records BuildOptions::sweep_size may name.
constexpr uint32_t kSweepNode = 16;

// Nodes of at most kFewBinsNode records are binned in at most kFewBins
// bins: setting up and pricing 16 bins on three axes cost more than
// binning a few records into them. Builds 1.02x to 1.06x faster (Sponza,
// the conference room, the car, Lost Empire), SAH costs within 0.05%, and
// the trace the same on 24 random views (0.99x to 1.01x).
constexpr uint32_t kFewBinsNode = 32;
constexpr int kFewBins = 8;

// Every axis's bins of one node (or of one chunk of a large node), set to
// empty for the bins in use before binning. Growing a bin then needs no
// test of whether it was written before: that test's branch mispredicts
// for most primitives of the many small nodes, where it cost more than the
// stores it saved. The sweep finds the occupied bins by their counts
// (marking them as they grow cost a tenth of the binning).
struct BinSet {
  v4f lo[3][kMaxBins], hi[3][kMaxBins];
  uint32_t counts[3][kMaxBins];
  int bins;
  explicit BinSet(int bin_count) : bins(bin_count) {
    const v4f inf = v4f{} + INFINITY;
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < bins; ++i) {
        lo[a][i] = inf;
        hi[a][i] = -inf;
        counts[a][i] = 0;
      }
  }
  void grow(int axis, int bin, v4f l, v4f h, uint32_t n = 1) {
    lo[axis][bin] = vmin(lo[axis][bin], l);
    hi[axis][bin] = vmax(hi[axis][bin], h);
    counts[axis][bin] += n;
  }
  void merge(const BinSet& o) {
    for (int a = 0; a < 3; ++a)
      for (int i = 0; i < bins; ++i)
        if (o.counts[a][i] != 0) grow(a, i, o.lo[a][i], o.hi[a][i], o.counts[a][i]);
  }
};

// Maps centres to bins on all three axes at once. Clamped in float first: a
// tiny centre extent makes the scale huge, and a float-to-int conversion of
// an out-of-range value is undefined. An axis whose centres are all alike
// has scale 0 and bins everything into bin 0.
struct Binner {
  v4f lo, scale, last;
  int bins;
  Binner(const Box4& centres, int bin_count) : bins(bin_count) {
    lo = centres.lo;
    for (int a = 0; a < 4; ++a) {
      const bool splittable = a < 3 && centres.hi[a] > centres.lo[a];
      scale[a] = splittable ? bins / (centres.hi[a] - centres.lo[a]) : 0.0f;
      if (a == 3) lo[a] = 0.0f;
    }
    last = v4f{} + static_cast<float>(bins - 1);
  }
  v4i bin(v4f centre) const {
    v4f f = (centre - lo) * scale;
    f = f > 0.0f ? f : v4f{};  // also NaN to 0
    f = f < last ? f : last;
    return __builtin_convertvector(f, v4i);
  }
};

struct Split {
  int axis = -1;
  int bin = 0;  // records in bins [0, bin] go left
  float cost = 0.0f;
  uint32_t weight = 0;  // the node's primitives (a pair counts two)
};

// A node still to be split, with the box of its primitives' centres.
struct Task {
  Task(uint32_t n, int d, const Box4& c) : node(n), depth(d), centres(c) {}
  uint32_t node;
  int depth;
  Box4 centres;
};

// Above this many records a node's binning and partition are spread over
// the threads.
constexpr uint32_t kParallelBinning = 1u << 15;

// Nodes of at most max(kSubtreeMin, records / kSubtrees) are whole
// subtrees built by one thread each, largest first; the nodes above them
// are split one thread a node (SplitSchedule). Subtrees of
// up to 2^15 primitives left a thread idle for a third of an unbalanced
// tree's build (a building's few large triangles and many small ones).
constexpr uint32_t kSubtreeMin = 1u << 12;
constexpr uint32_t kSubtrees = 32;

// The split rules (SAH over bins, object medians past median_depth or where
// SAH finds nothing) decide each node's primitive set from the set alone,
// so the tree does not depend on the thread count or the order of the work.
class Builder {
 public:
  // `staging`: room for as many records as `refs`, the large nodes'
  // partition's (each node uses its own range, so nodes split side by side
  // share it); null when no node is large enough to need it.
  Builder(LargeArray<PrimRef>& refs, const BuildOptions& opt, PrimRef* staging)
      : refs_(refs), opt_(opt), staging_(staging) {
    RF_CHECK(opt_.bins >= 2 && opt_.bins <= kMaxBins, "bin count out of range");
    RF_CHECK_LE(opt_.sweep_size, kSweepNode, "sweep size out of range");
  }

  // Builds the subtree under nodes[0] (its range and box already set) into
  // `nodes`, given its centres' box and level; returns the deepest level.
  int build_subtree(PageAlignedVector<BuildNode>& nodes, const Box4& root_centres, int root_depth) const {
    int depth = root_depth;
    // Depth first, the left child next without a trip through the stack:
    // a task pushed and popped at once was copied whole from two 4-byte
    // stores (a failed store-to-load forward, 6% of Sponza's build).
    std::vector<Task> stack;
    Task task(0, root_depth, root_centres);
    for (;;) {
      depth = std::max(depth, task.depth);
      Box4 children[2];
      if (subdivide(nodes, task, 1, children)) {
        const BuildNode& n = nodes[task.node];
        stack.emplace_back(n.right, task.depth + 1, children[1]);
        task = Task(n.left, task.depth + 1, children[0]);
        continue;
      }
      if (stack.empty()) break;
      task = stack.back();
      stack.pop_back();
    }
    return depth;
  }

  // Splits the task's node in two (appending both children, their centre
  // boxes to `children`); false when it stays a leaf. `threads` > 1 bins it
  // in parallel.
  bool subdivide(PageAlignedVector<BuildNode>& nodes, const Task& task, unsigned threads, Box4 children[2]) const {
    const uint32_t ni = task.node;
    const int depth = task.depth;
    const uint32_t first = nodes[ni].first, count = nodes[ni].count;
    if (count <= 1) return false;
    const Box4& cb = task.centres;
    uint32_t mid = first;
    Box4 lbox, rbox, lcentres, rcentres;
    if (depth >= opt_.median_depth) {
      uint32_t weight = 0;
      for (uint32_t i = first; i < first + count; ++i) weight += refs_[i].weight();
      if (weight <= opt_.max_leaf_size) return false;
    } else if (count <= opt_.sweep_size) {
      uint8_t order[kSweepNode];
      const Split split = sweep_split(first, count, nodes[ni].bounds, order);
      const float leaf_cost = opt_.intersection_cost * static_cast<float>(split.weight);
      // No boundary priced (areas that are not numbers): `order` is unwritten,
      // and the median split below takes the node.
      const bool sah_prefers_leaf = split.axis < 0 || split.cost >= leaf_cost;
      if (sah_prefers_leaf && split.weight <= opt_.max_leaf_size) return false;
      if (split.axis >= 0) mid = apply_sweep(first, count, split, order, lbox, rbox, lcentres, rcentres);
    } else {
      const Binner binner(cb, count <= kFewBinsNode ? std::min(opt_.bins, kFewBins) : opt_.bins);
      const Split split = find_split(first, count, binner, nodes[ni].bounds, threads);
      const float leaf_cost = opt_.intersection_cost * static_cast<float>(split.weight);
      const bool sah_prefers_leaf = split.axis < 0 || split.cost >= leaf_cost;
      if (sah_prefers_leaf && split.weight <= opt_.max_leaf_size) return false;
      if (split.axis >= 0) mid = partition(first, count, binner, split, threads, lbox, rbox, lcentres, rcentres);
    }
    if (mid == first || mid == first + count) {
      // No useful SAH split (all centres alike, or too deep): split at the
      // object median of the widest centre axis, which always terminates.
      const v4f e = cb.hi - cb.lo;
      const int axis = (e[0] >= e[1] && e[0] >= e[2]) ? 0 : (e[1] >= e[2] ? 1 : 2);
      mid = first + count / 2;
      std::nth_element(refs_.data() + first, refs_.data() + mid, refs_.data() + first + count,
                       [axis](const PrimRef& a, const PrimRef& b) {
                         const float ca = a.centre()[axis], cb = b.centre()[axis];
                         if (ca != cb) return ca < cb;
                         return a.index() < b.index();
                       });
      lbox = rbox = lcentres = rcentres = Box4();
      for (uint32_t i = first; i < first + count; ++i) {
        const PrimRef& r = refs_[i];
        (i < mid ? lbox : rbox).grow(r.box_lo(), r.hi);
        const v4f c = r.centre();
        (i < mid ? lcentres : rcentres).grow(c, c);
      }
    }
    const uint32_t li = static_cast<uint32_t>(nodes.size());
    BuildNode left, right;
    left.bounds = lbox.aabb();
    left.first = first;
    left.count = mid - first;
    right.bounds = rbox.aabb();
    right.first = mid;
    right.count = first + count - mid;
    nodes.push_back(left);
    nodes.push_back(right);
    children[0] = lcentres;
    children[1] = rcentres;
    BuildNode& parent = nodes[ni];  // push_back may have moved it
    parent.left = li;
    parent.right = li + 1;
    parent.count = 0;
    return true;
  }

 private:
  // A small node's split: every boundary between its primitives ordered by
  // centre on each axis (ties by index), priced exactly. On the smallest
  // nodes a bin set's set-up and sweep cost more than their binning, and the
  // bins' boundaries are a subset of these. The order is by counting ranks,
  // which has no branches to mispredict; its cost grows with the square of
  // the count (the dragon's build ran the fewest instructions at a sweep
  // size of 4, of 1, 4, 8 and 16). `bin` is how many go left; `order`
  // receives the chosen axis's order.
  Split sweep_split(uint32_t first, uint32_t count, const Aabb& node_bounds, uint8_t order[kSweepNode]) const {
    const PrimRef* r = refs_.data() + first;
    float key[3][kSweepNode];
    uint32_t index[kSweepNode], weight[kSweepNode];
    uint32_t total = 0;
    for (uint32_t k = 0; k < count; ++k) {
      const v4f c = r[k].centre();
      // A centre that is not a number (a box of infinite extent both ways)
      // ranks last: the ranks below need a total order, or two records
      // take one rank and the order reads a slot it never wrote.
      for (int axis = 0; axis < 3; ++axis) key[axis][k] = c[axis] == c[axis] ? c[axis] : INFINITY;
      index[k] = r[k].index();
      weight[k] = r[k].weight();
      total += weight[k];
    }
    Split best;
    best.weight = total;
    float best_sum = INFINITY;  // area times count, both sides
    // Two records part the same way on every axis, each side one record:
    // the other axes' sums are the same two products added in either
    // order, the same bits, which the strict comparison never takes over
    // the first's. A fifth of the nodes split hold two records.
    const int axes = count == 2 ? 1 : 3;
    for (int axis = 0; axis < axes; ++axis) {
      uint8_t o[kSweepNode];
      const float* kk = key[axis];
      for (uint32_t k = 0; k < count; ++k) {
        uint32_t rank = 0;
        // Bitwise, not || and &&: the compiler made those branches, and
        // they mispredicted on most nodes.
        for (uint32_t j = 0; j < count; ++j)
          rank += static_cast<uint32_t>(kk[j] < kk[k]) |
                  (static_cast<uint32_t>(kk[j] == kk[k]) & static_cast<uint32_t>(index[j] < index[k]));
        o[rank] = static_cast<uint8_t>(k);
      }
      float right[kSweepNode];
      Box4 acc;
      uint32_t n = 0;
      for (uint32_t j = count - 1; j > 0; --j) {
        acc.grow(r[o[j]].box_lo(), r[o[j]].hi);
        n += weight[o[j]];
        right[j] = acc.half_area() * static_cast<float>(n);
      }
      acc = Box4();
      n = 0;
      for (uint32_t j = 0; j + 1 < count; ++j) {
        acc.grow(r[o[j]].box_lo(), r[o[j]].hi);
        n += weight[o[j]];
        const float sum = acc.half_area() * static_cast<float>(n) + right[j + 1];
        if (sum < best_sum) {
          best_sum = sum;
          best.axis = axis;
          best.bin = static_cast<int>(j + 1);
        }
      }
      if (best.axis == axis) std::memcpy(order, o, count);
    }
    const float parent_area = std::max(node_bounds.half_area(), 1e-30f);
    best.cost = opt_.traversal_cost + opt_.intersection_cost * best_sum / parent_area;
    return best;
  }

  // Puts the sweep's left primitives first, in their order along its axis;
  // returns the first right one, with both sides' boxes and centre boxes.
  uint32_t apply_sweep(uint32_t first, uint32_t count, const Split& split, const uint8_t* order, Box4& lbox, Box4& rbox,
                       Box4& lcentres, Box4& rcentres) const {
    PrimRef* r = refs_.data() + first;
    PrimRef sorted[kSweepNode];
    for (uint32_t k = 0; k < count; ++k) sorted[k] = r[order[k]];
    for (uint32_t k = 0; k < count; ++k) {
      r[k] = sorted[k];
      const v4f c = r[k].centre();
      const bool left = k < static_cast<uint32_t>(split.bin);
      (left ? lbox : rbox).grow(r[k].box_lo(), r[k].hi);
      (left ? lcentres : rcentres).grow(c, c);
    }
    return first + static_cast<uint32_t>(split.bin);
  }

  void bin_range(uint32_t begin, uint32_t end, const Binner& binner, BinSet& bins) const {
    for (uint32_t i = begin; i < end; ++i) {
      const PrimRef& r = refs_[i];
      const v4i b = binner.bin(r.centre());
      const uint32_t w = r.weight();
      for (int axis = 0; axis < 3; ++axis) bins.grow(axis, b[axis], r.box_lo(), r.hi, w);
    }
  }

  // Bins the node (in chunks over `threads` threads when it is large), then
  // prices the boundary after every occupied bin of every axis. An empty
  // bin changes neither side, so the boundaries after it price the same as
  // the one before them and, the comparison being strict, are never chosen.
  Split find_split(uint32_t first, uint32_t count, const Binner& binner, const Aabb& node_bounds,
                   unsigned threads) const {
    BinSet bins(binner.bins);
    if (threads > 1 && count > kParallelBinning) {
      constexpr uint32_t kChunk = 1u << 14;
      const size_t chunks = (count + kChunk - 1) / kChunk;
      std::vector<BinSet> partial(chunks, BinSet(binner.bins));
      parallel_for(chunks, threads, 1, [&](size_t c, size_t) {
        const uint32_t b = first + static_cast<uint32_t>(c) * kChunk;
        bin_range(b, std::min(first + count, b + kChunk), binner, partial[c]);
      });
      for (const BinSet& p : partial) bins.merge(p);
    } else {
      bin_range(first, first + count, binner, bins);
    }

    // Prices compare as area times count summed over both sides: the
    // traversal cost added and the parent's area divided once, for the
    // best, keep the order (both are monotonic).
    Split best;
    for (int i = 0; i < binner.bins; ++i) best.weight += bins.counts[0][i];
    float best_sum = INFINITY;
    for (int axis = 0; axis < 3; ++axis) {
      if (binner.scale[axis] == 0.0f) continue;
      int occupied[kMaxBins];
      int m = 0;
      for (int i = 0; i < binner.bins; ++i) {
        occupied[m] = i;
        m += bins.counts[axis][i] != 0;
      }
      // Sweep from the right to know each right side's area times count.
      float right[kMaxBins];
      Box4 acc;
      uint32_t n = 0;
      for (int j = m - 1; j > 0; --j) {
        const int i = occupied[j];
        acc.grow(bins.lo[axis][i], bins.hi[axis][i]);
        n += bins.counts[axis][i];
        right[j] = acc.half_area() * static_cast<float>(n);
      }
      acc = Box4();
      n = 0;
      for (int j = 0; j + 1 < m; ++j) {
        const int i = occupied[j];
        acc.grow(bins.lo[axis][i], bins.hi[axis][i]);
        n += bins.counts[axis][i];
        const float sum = acc.half_area() * static_cast<float>(n) + right[j + 1];
        if (sum < best_sum) {
          best_sum = sum;
          best.axis = axis;
          best.bin = i;
        }
      }
    }
    const float parent_area = std::max(node_bounds.half_area(), 1e-30f);
    best.cost = best.axis < 0 ? INFINITY : opt_.traversal_cost + opt_.intersection_cost * best_sum / parent_area;
    return best;
  }

  // Moves the split's left primitives to the front of the range; returns
  // the first right one, with both sides' boxes and centre boxes. `threads`
  // > 1 partitions a large node in parallel.
  uint32_t partition(uint32_t first, uint32_t count, const Binner& binner, const Split& split, unsigned threads,
                     Box4& lbox, Box4& rbox, Box4& lcentres, Box4& rcentres) const {
    auto goes_left = [&](const PrimRef& r) { return binner.bin(r.centre())[split.axis] <= split.bin; };
    if (count > kParallelBinning) {
      // Stable, in fixed chunks: each chunk's sides are counted and boxed,
      // then its records copied to their places and back, so the order is
      // the same on any thread count. A serial partition of the root level
      // left the other thread idle for half of it.
      constexpr uint32_t kChunk = 1u << 14;
      const size_t chunks = (count + kChunk - 1) / kChunk;
      std::vector<uint32_t> lefts(chunks + 1, 0);
      std::vector<std::array<Box4, 4>> boxes(chunks);  // left, right, left centres, right centres
      parallel_for(chunks, threads, 1, [&](size_t c, size_t) {
        const uint32_t b = first + static_cast<uint32_t>(c) * kChunk, e = std::min(first + count, b + kChunk);
        uint32_t l = 0;
        for (uint32_t i = b; i < e; ++i) {
          const PrimRef& p = refs_[i];
          const v4f centre = p.centre();
          const bool left = goes_left(p);
          l += left;
          boxes[c][!left].grow(p.box_lo(), p.hi);
          boxes[c][2 + !left].grow(centre, centre);
        }
        lefts[c + 1] = l;
      });
      for (size_t c = 0; c < chunks; ++c) {
        lefts[c + 1] += lefts[c];
        lbox.grow(boxes[c][0]);
        rbox.grow(boxes[c][1]);
        lcentres.grow(boxes[c][2]);
        rcentres.grow(boxes[c][3]);
      }
      const uint32_t total_left = lefts[chunks];
      PrimRef* const sorted = staging_ + first;
      parallel_for(chunks, threads, 1, [&](size_t c, size_t) {
        const uint32_t b = static_cast<uint32_t>(c) * kChunk, e = std::min(count, b + kChunk);
        uint32_t l = lefts[c], r = total_left + (b - lefts[c]);
        for (uint32_t i = b; i < e; ++i) {
          const PrimRef& p = refs_[first + i];
          if (goes_left(p))
            sorted[l++] = p;
          else
            sorted[r++] = p;
        }
      });
      parallel_for(chunks, threads, 1, [&](size_t c, size_t) {
        const uint32_t b = static_cast<uint32_t>(c) * kChunk, e = std::min(count, b + kChunk);
        std::memcpy(refs_.data() + first + b, sorted + b, (e - b) * sizeof(PrimRef));
      });
      return first + total_left;
    }
    // Without branches on the side, which is a coin toss for the branch
    // predictor: each record is copied to the next free slot of its side
    // (left from the front, right from the back) and the boxes grow by
    // index; the range is then copied back.
    thread_local std::vector<PrimRef> scratch;
    if (scratch.size() < count) scratch.resize(std::max<size_t>(count, 1024));
    Box4 boxes[2], centres[2];
    uint32_t l = 0, r = count;
    const PrimRef* in = refs_.data() + first;
    for (uint32_t k = 0; k < count; ++k) {
      const PrimRef& p = in[k];
      const v4f c = p.centre();
      const bool left = binner.bin(c)[split.axis] <= split.bin;
      r -= !left;
      scratch[left ? l : r] = p;
      l += left;
      boxes[!left].grow(p.box_lo(), p.hi);
      centres[!left].grow(c, c);
    }
    std::memcpy(refs_.data() + first, scratch.data(), count * sizeof(PrimRef));
    lbox = boxes[0];
    rbox = boxes[1];
    lcentres = centres[0];
    rcentres = centres[1];
    return first + l;
  }

  LargeArray<PrimRef>& refs_;
  const BuildOptions& opt_;
  PrimRef* const staging_;
};

// The large nodes (more than subtree_size primitives) are split one by one,
// and the subtrees below them built whole, by a pool of threads that takes
// whatever is ready, largest first: a level-by-level split waited at every
// level for its slowest node, and the subtrees for the last level (on the
// conference room the levels scaled 1.5x on two threads, the subtrees
// 1.85x). Which primitives each node holds depends on its set alone, so the
// pool's order changes nothing but when; number() then gives the nodes the
// numbers a level-by-level build on one thread gives them, which flatten_bvh
// keeps, so the tree is the same on any thread count.
class SplitSchedule {
 public:
  SplitSchedule(const Builder& builder, uint32_t subtree_size, const BuildNode& root, const Box4& root_centres)
      : builder_(builder), subtree_size_(subtree_size) {
    add(root, root_centres, 1);
  }

  // Splits every large node and builds every subtree on `threads` threads.
  // While fewer large nodes are ready than there are threads, each is split
  // with all of them binning it, before the pool starts.
  void run(unsigned threads) {
    while (!ready_large_.empty() && ready_large_.size() < threads) {
      std::vector<uint32_t> now;
      now.swap(ready_large_);
      for (uint32_t id : now) split(pieces_[id], threads);
    }
    std::vector<std::thread> pool;
    for (unsigned t = 1; t < threads; ++t) pool.emplace_back([this] { work(); });
    work();
    for (std::thread& t : pool) t.join();
    if (failure_) std::rethrow_exception(failure_);
  }

  // Writes the nodes into `tree` in the numbering of a level-by-level build:
  // each level's large nodes' children appended in level order, then every
  // subtree's nodes after its root, largest subtree first.
  void number(BuildTree& tree, unsigned threads) {
    std::vector<uint32_t> node_of(pieces_.size(), 0), subtrees, level{0};
    tree.nodes.push_back(pieces_[0].node);
    while (!level.empty()) {
      std::vector<uint32_t> next;
      for (uint32_t id : level) {
        tree.depth = std::max(tree.depth, pieces_[id].depth);
        if (!pieces_[id].large) subtrees.push_back(id);
      }
      for (uint32_t id : level) {
        const Piece& p = pieces_[id];
        if (!p.large) continue;
        BuildNode& node = tree.nodes[node_of[id]];
        node = p.node;
        if (!p.split) continue;
        const uint32_t li = static_cast<uint32_t>(tree.nodes.size());
        node.left = li;
        node.right = li + 1;
        for (int c = 0; c < 2; ++c) {
          node_of[p.child[c]] = li + c;
          tree.nodes.push_back(pieces_[p.child[c]].node);
          next.push_back(p.child[c]);
        }
      }
      level.swap(next);
    }
    std::stable_sort(subtrees.begin(), subtrees.end(),
                     [&](uint32_t a, uint32_t b) { return pieces_[a].node.count > pieces_[b].node.count; });
    // Each subtree's root takes its placeholder's place; the rest follow, so
    // that children still come after their parents. The copies go side by
    // side: each subtree's place is known from the sizes before it.
    std::vector<size_t> offsets(subtrees.size() + 1, tree.nodes.size());
    for (size_t s = 0; s < subtrees.size(); ++s) offsets[s + 1] = offsets[s] + pieces_[subtrees[s]].nodes.size() - 1;
    tree.nodes.resize(offsets.back());
    parallel_for(subtrees.size(), threads, 1, [&](size_t s, size_t) {
      Piece& p = pieces_[subtrees[s]];
      const uint32_t offset = static_cast<uint32_t>(offsets[s]) - 1;
      for (size_t k = 0; k < p.nodes.size(); ++k) {
        BuildNode n = p.nodes[k];
        if (!n.is_leaf()) {
          n.left += offset;
          n.right += offset;
        }
        tree.nodes[k == 0 ? node_of[subtrees[s]] : offset + k] = n;
      }
      PageAlignedVector<BuildNode>().swap(p.nodes);
    });
    for (uint32_t id : subtrees) tree.depth = std::max(tree.depth, pieces_[id].subtree_depth);
  }

 private:
  struct Piece {
    BuildNode node;  // large: as split (its children's numbers are set by number()); subtree: its root
    Box4 centres;
    int depth;
    bool large;
    bool split = false;
    uint32_t child[2] = {0, 0};          // pieces of a split large node's children
    PageAlignedVector<BuildNode> nodes;  // a subtree's nodes, its root first, as build_subtree numbers them
    int subtree_depth = 0;
  };

  // Adds a piece (under mutex_ once the pool runs) and makes it ready.
  uint32_t add(const BuildNode& node, const Box4& centres, int depth) {
    const uint32_t id = static_cast<uint32_t>(pieces_.size());
    Piece& p = pieces_.emplace_back();
    p.node = node;
    p.centres = centres;
    p.depth = depth;
    p.large = node.count > subtree_size_;
    (p.large ? ready_large_ : ready_subtrees_).push_back(id);
    return id;
  }

  // Splits a large piece (outside mutex_), its children added under it.
  void split(Piece& p, unsigned threads, std::unique_lock<std::mutex>* lock = nullptr) {
    PageAlignedVector<BuildNode> out{p.node};
    Box4 centres[2];
    p.split = builder_.subdivide(out, Task{0, p.depth, p.centres}, threads, centres);
    p.node = out[0];
    if (!p.split) return;
    if (lock) lock->lock();
    for (int c = 0; c < 2; ++c) p.child[c] = add(out[1 + c], centres[c], p.depth + 1);
  }

  // The ready piece of most primitives, taken off `ready`.
  uint32_t take_largest(std::vector<uint32_t>& ready) {
    size_t best = 0;
    for (size_t k = 1; k < ready.size(); ++k)
      if (pieces_[ready[k]].node.count > pieces_[ready[best]].node.count) best = k;
    const uint32_t id = ready[best];
    ready.erase(ready.begin() + static_cast<std::ptrdiff_t>(best));
    return id;
  }

  // One thread of the pool: splits ready large nodes first (their children
  // are the work still to come), else builds the largest ready subtree,
  // else waits for a split in progress; returns when nothing is left.
  void work() {
    std::unique_lock<std::mutex> lock(mutex_);
    while (!failure_) {
      if (!ready_large_.empty() || !ready_subtrees_.empty()) {
        const bool large = !ready_large_.empty();
        Piece& p = pieces_[take_largest(large ? ready_large_ : ready_subtrees_)];  // deque: p stays put
        splitting_ += large;
        lock.unlock();
        try {
          if (large) {
            split(p, 1, &lock);  // returns locked when it split
            if (!lock.owns_lock()) lock.lock();
            --splitting_;
            cv_.notify_all();
          } else {
            p.nodes.reserve(2 * size_t{p.node.count} - 1);  // a binary tree's node count at most
            p.nodes.push_back(p.node);
            p.subtree_depth = builder_.build_subtree(p.nodes, p.centres, p.depth);
            lock.lock();
          }
        } catch (...) {
          if (!lock.owns_lock()) lock.lock();
          if (large && splitting_ > 0) --splitting_;
          if (!failure_) failure_ = std::current_exception();
          cv_.notify_all();
        }
      } else if (splitting_ == 0) {
        cv_.notify_all();
        return;
      } else {
        cv_.wait(lock);
      }
    }
  }

  const Builder& builder_;
  const uint32_t subtree_size_;
  std::deque<Piece> pieces_;  // a deque: adding one moves none, so a thread keeps its piece while others add
  std::vector<uint32_t> ready_large_, ready_subtrees_;
  unsigned splitting_ = 0;
  std::exception_ptr failure_;
  std::mutex mutex_;
  std::condition_variable cv_;
};

// Summed over fixed chunks of the node array, side by side, and the
// chunks' sums in order: the same bits on any thread count, the numbering
// being the same on any (SplitSchedule::number). A walk from the root, one
// thread, was 3% of the car's build.
double sah_cost(const BuildTree& tree, const BuildOptions& opt, unsigned threads) {
  const double root_area = std::max<double>(tree.nodes[0].bounds.half_area(), 1e-300);
  constexpr size_t kChunk = size_t{1} << 14;
  std::vector<double> sums((tree.nodes.size() + kChunk - 1) / kChunk, 0.0);
  parallel_for(tree.nodes.size(), threads, kChunk, [&](size_t begin, size_t end) {
    double sum = 0.0;
    for (size_t i = begin; i < end; ++i) {
      const BuildNode& n = tree.nodes[i];
      const double a = n.bounds.half_area() / root_area;
      sum += n.is_leaf() ? a * opt.intersection_cost * n.count : a * opt.traversal_cost;
    }
    sums[begin / kChunk] = sum;
  });
  double cost = 0.0;
  for (double sum : sums) cost += sum;
  return cost;
}

// The record that starts at primitive i, below `end`: with `pair`, i and
// i + 1 as one pair record where their box's area is at most 1.5 times the
// smaller of theirs (the halves of an axis-aligned quad give 1), else i
// alone; none for an empty box (`made` false). A record's key is its first
// index times 2, plus 1 for a pair. Returns the primitives it takes, 1 or 2.
// A rule on the sum of the two areas (at most 7/8 of it) also paired large
// triangles with small ones inside their boxes: the trees' SAH costs stayed
// within 2.3%, but on random views of the conference room the tile kernel
// tested up to 2.4 times the triangles per pixel. With this rule the
// counters of every scene are within 4% of unpaired trees'.
size_t make_record(const Aabb* bounds, size_t end, size_t i, bool pair, PrimRef& out, bool& made) {
  auto record = [&](const Aabb& b, uint32_t flag) {
    const uint32_t key = static_cast<uint32_t>(i) << 1 | flag;
    float key_bits;
    std::memcpy(&key_bits, &key, 4);
    out = PrimRef{v4f{b.lo.x, b.lo.y, b.lo.z, key_bits}, v4f{b.hi.x, b.hi.y, b.hi.z, 0.0f}};
  };
  const Aabb& a = bounds[i];
  made = !a.empty();
  if (!made) return 1;
  if (pair && i + 1 < end && !bounds[i + 1].empty()) {
    const Aabb& b = bounds[i + 1];
    Aabb both = a;
    both.grow(b);
    const float area = both.half_area();  // 0: lines, which would pair however far apart
    if (area > 0.0f && area <= 1.5f * std::min(a.half_area(), b.half_area())) {
      record(both, 1u);
      return 2;
    }
  }
  record(a, 0u);
  return 1;
}

// The records of every primitive with a box, with their boxes' and
// centres' boxes, chunk by chunk side by side: each chunk's records are
// counted, then written from the chunk's offset on, so the order is the
// same on any thread count. With `pair`, each chunk is paired greedily in
// index order: a primitive that does not pair with the next leaves that
// one free to pair with its own next (the sports car's triangles pair 80%
// so, 30% as 2i and 2i + 1 only). Pairs never straddle two chunks.
LargeArray<PrimRef> make_all_records(const Aabb* bounds, size_t count, bool pair, unsigned threads, Box4& boxes,
                                     Box4& centres) {
  constexpr size_t kChunk = size_t{1} << 14;
  const size_t chunks = (count + kChunk - 1) / kChunk;
  std::vector<size_t> offsets(chunks + 1, 0);
  parallel_for(chunks, threads, 1, [&](size_t c, size_t) {
    const size_t end = std::min(count, (c + 1) * kChunk);
    PrimRef r;
    bool made = false;
    for (size_t i = c * kChunk; i < end; offsets[c + 1] += made) i += make_record(bounds, end, i, pair, r, made);
  });
  for (size_t c = 0; c < chunks; ++c) offsets[c + 1] += offsets[c];
  LargeArray<PrimRef> refs(offsets[chunks]);  // each written below
  std::vector<Box4> chunk_boxes(chunks), chunk_centres(chunks);
  parallel_for(chunks, threads, 1, [&](size_t c, size_t) {
    const size_t end = std::min(count, (c + 1) * kChunk);
    PrimRef* out = refs.data() + offsets[c];
    // Grown in locals: grown in chunk_boxes[c], each record waited on the
    // last one's store (half of this pass's time).
    Box4 chunk_box, chunk_centre;
    PrimRef r;
    bool made = false;
    for (size_t i = c * kChunk; i < end;) {
      i += make_record(bounds, end, i, pair, r, made);
      if (!made) continue;
      *out++ = r;
      chunk_box.grow(r.box_lo(), r.hi);
      const v4f centre = r.centre();
      chunk_centre.grow(centre, centre);
    }
    RF_CHECK(out == refs.data() + offsets[c + 1], "records of chunk " + std::to_string(c) + " counted " +
                                                      std::to_string(offsets[c + 1] - offsets[c]) + ", written " +
                                                      std::to_string(out - refs.data() - offsets[c]));
    chunk_boxes[c] = chunk_box;
    chunk_centres[c] = chunk_centre;
  });
  for (size_t c = 0; c < chunks; ++c) {
    boxes.grow(chunk_boxes[c]);
    centres.grow(chunk_centres[c]);
  }
  return refs;
}

// The leaf order in primitives, and each node's range counted in them
// rather than in records.
void expand_records(BuildTree& tree, const LargeArray<PrimRef>& refs, unsigned threads) {
  std::vector<uint32_t> before(refs.size() + 1, 0);  // primitives in the records before each
  for (size_t i = 0; i < refs.size(); ++i) before[i + 1] = before[i] + refs[i].weight();
  tree.order.resize(before.back());
  constexpr size_t kChunk = size_t{1} << 14;
  parallel_for(refs.size(), threads, kChunk, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i) {
      const uint32_t index = refs[i].index();
      tree.order[before[i]] = index;
      if (refs[i].weight() == 2) tree.order[before[i] + 1] = index + 1;
    }
  });
  if (before.back() == refs.size()) return;  // no pair: the ranges are the same
  parallel_for(tree.nodes.size(), threads, kChunk, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) {
      BuildNode& n = tree.nodes[k];
      const uint32_t first = before[n.first];
      if (n.is_leaf()) n.count = before[n.first + n.count] - first;
      n.first = first;
    }
  });
}

}  // namespace

BuildTree build_sah(const Aabb* prim_bounds, size_t count, const BuildOptions& options, unsigned threads) {
  threads = resolve_threads(threads);
  if (count >= (size_t{1} << 31))
    throw InputError("", "a tree of " + std::to_string(count) + " primitives: at most 2^31 - 1 in one tree");
  BuildTree tree;
  // A pair is a leaf of two at least, which a limit of one forbids.
  const bool pair = options.pair_primitives && options.max_leaf_size >= 2;
  Box4 root_box, root_centres;
  LargeArray<PrimRef> refs = make_all_records(prim_bounds, count, pair, threads, root_box, root_centres);
  if (refs.empty()) return tree;

  // One staging array for every large node's partition: a fresh one per
  // node was a fresh page for every record at every large level (a fifth
  // of the conference room's page faults). No zeroing: every slot a node
  // uses is written before it is read.
  LargeArray<PrimRef> staging(refs.size() > kParallelBinning ? refs.size() : 0);
  const Builder builder(refs, options, staging.data());
  BuildNode root;
  root.bounds = root_box.aabb();
  root.count = static_cast<uint32_t>(refs.size());
  const uint32_t subtree_size = std::max<uint32_t>(kSubtreeMin, static_cast<uint32_t>(refs.size() / kSubtrees));
  if (root.count <= subtree_size) {
    // A tree too small to share: built in place.
    tree.nodes.reserve(2 * refs.size() - 1);  // a binary tree's node count at most
    tree.nodes.push_back(root);
    tree.depth = builder.build_subtree(tree.nodes, root_centres, 1);
  } else {
    SplitSchedule schedule(builder, subtree_size, root, root_centres);
    schedule.run(threads);
    staging = LargeArray<PrimRef>();  // the subtrees' nodes are copied next: not at the peak beside them
    schedule.number(tree, threads);
  }
  expand_records(tree, refs, threads);
  tree.sah_cost = sah_cost(tree, options, threads);
  return tree;
}

}  // namespace rayfold::core
