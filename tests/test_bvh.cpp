// The trees against brute force: every pixel of many random views over random
// scenes (mirrors, non-uniform scales, zero-area triangles) must give exactly
// the brute-force hit, and the trees must satisfy their structural invariants.
#include <gtest/gtest.h>

#include <malloc.h>
#include <algorithm>
#include <cstring>
#include <numeric>
#include <set>

#include <glm/gtc/matrix_transform.hpp>

#include "bvh/blas.h"
#include "bvh/bvh_build.h"
#include "bvh/bvh_flatten.h"
#include "bvh/wide_bvh.h"
#include "fold/ray_list.h"
#include "reference/cpu_tracer.h"
#include "pipeline/pipeline.h"
#include "rf_trace.h"
#include "test_util.h"
#include "util/large_pages.h"

namespace rayfold::core {
namespace {

using testing::Rng;

void check_tree(const BuildTree& tree, const std::vector<Aabb>& boxes) {
  ASSERT_FALSE(tree.nodes.empty());
  EXPECT_LE(tree.depth, RF_STACK_SIZE);
  std::multiset<uint32_t> seen(tree.order.begin(), tree.order.end());
  EXPECT_EQ(seen.size(), boxes.size());
  EXPECT_EQ(std::set<uint32_t>(tree.order.begin(), tree.order.end()).size(), boxes.size());
  for (const BuildNode& n : tree.nodes) {
    if (n.is_leaf()) {
      for (uint32_t i = n.first; i < n.first + n.count; ++i) {
        const Aabb& b = boxes[tree.order[i]];
        for (int k = 0; k < 3; ++k) {
          EXPECT_LE(n.bounds.lo[k], b.lo[k]);
          EXPECT_GE(n.bounds.hi[k], b.hi[k]);
        }
      }
    } else {
      for (uint32_t c : {n.left, n.right})
        for (int k = 0; k < 3; ++k) {
          EXPECT_LE(n.bounds.lo[k], tree.nodes[c].bounds.lo[k]);
          EXPECT_GE(n.bounds.hi[k], tree.nodes[c].bounds.hi[k]);
        }
    }
  }
}

TEST(Bvh, BuildInvariantsOnRandomBoxes) {
  Rng rng(11);
  for (int n : {1, 2, 3, 17, 1000, 20000}) {
    std::vector<Aabb> boxes(n);
    for (Aabb& b : boxes) {
      const glm::vec3 c(rng.uniformf(-100, 100), rng.uniformf(-1, 1), rng.uniformf(-100, 100));
      b.grow(c);
      b.grow(c + glm::vec3(rng.uniformf(0, 3), rng.uniformf(0, 3), rng.uniformf(0, 3)));
    }
    check_tree(build_sah(boxes), boxes);
  }
}

TEST(Bvh, IdenticalBoxesStillTerminateWithinStackDepth) {
  // All centroids equal: SAH cannot split, the median fallback must.
  std::vector<Aabb> boxes(100000);
  for (Aabb& b : boxes) {
    b.grow(glm::vec3(0.0f));
    b.grow(glm::vec3(1.0f));
  }
  const BuildTree tree = build_sah(boxes);
  check_tree(tree, boxes);
}

TEST(Bvh, PathologicalSpreadStaysWithinStackDepth) {
  // Exponentially spaced boxes tempt SAH into peeling one box per level.
  std::vector<Aabb> boxes;
  for (int i = 0; i < 5000; ++i) {
    Aabb b;
    const float x = std::ldexp(1.0f, i % 120 - 60) * (1 + i / 120);
    b.grow(glm::vec3(x, 0, 0));
    b.grow(glm::vec3(x * 1.001f, 1, 1));
    boxes.push_back(b);
  }
  check_tree(build_sah(boxes), boxes);
}

// Clustered boxes with duplicates (equal centres exercise the median
// fallback), over 2^15 of them so that the parallel levels run.
std::vector<Aabb> clustered_boxes(Rng& rng, int n) {
  std::vector<Aabb> boxes;
  while (static_cast<int>(boxes.size()) < n) {
    const glm::vec3 c(rng.uniformf(-100, 100), rng.uniformf(-5, 5), rng.uniformf(-100, 100));
    const int copies = rng.below(50) == 0 ? 12 : 1 + rng.below(4) * rng.below(2);  // 12 > max_leaf_size
    const glm::vec3 size(rng.uniformf(0, 2), rng.uniformf(0, 2), rng.uniformf(0, 2));
    for (int k = 0; k < copies; ++k) {
      Aabb b;
      b.grow(c);
      b.grow(c + size);
      boxes.push_back(b);
    }
  }
  boxes.resize(n);
  return boxes;
}

TEST(Bvh, BuildIsTheSameOnAnyThreadCount) {
  Rng rng(77);
  const std::vector<Aabb> boxes = clustered_boxes(rng, 150000);
  std::vector<rf_node> reference;
  BuildTree one = build_sah(boxes, BuildOptions{}, 1);
  flatten_bvh(one, 0, nullptr, 0, reference);
  for (unsigned threads : {2u, 3u, 8u}) {
    const BuildTree tree = build_sah(boxes, BuildOptions{}, threads);
    std::vector<rf_node> flat;
    flatten_bvh(tree, 0, nullptr, 0, flat);
    ASSERT_EQ(flat.size(), reference.size()) << threads << " threads";
    EXPECT_EQ(std::memcmp(flat.data(), reference.data(), flat.size() * sizeof(rf_node)), 0) << threads << " threads";
    EXPECT_EQ(tree.order, one.order) << threads << " threads";
    EXPECT_EQ(tree.depth, one.depth) << threads << " threads";
    EXPECT_EQ(tree.sah_cost, one.sah_cost) << threads << " threads";
    check_tree(tree, boxes);
  }
}

// Every byte of a scene's device arrays (bottom-level nodes, triangles,
// wide nodes) is written by the build: they are not zeroed first
// (util/page_aligned.h), so a byte left unwritten would hold whatever the
// memory held. Two builds into memory filled with different bytes (kept
// blocks poisoned, malloc's memory perturbed) must give the same bytes.
TEST(Bvh, EveryByteOfTheDeviceArraysIsWritten) {
  // Triangle soups under random transforms (merged where they share one),
  // and a closed lattice cube large enough that every array is over
  // kLargeArrayBytes: mapped, kept and reused.
  Rng rng(91);
  Scene scene = testing::random_scene(rng, 3, 6, 4000);
  scene.meshes.push_back(testing::closed_cube(180));
  Instance cube;
  cube.mesh = static_cast<uint32_t>(scene.meshes.size() - 1);
  scene.instances.push_back(cube);
  prepare_scene(scene, 2);  // dropped: its arrays are kept for the builds below
  auto build = [&](unsigned char byte) {
    poison_kept_large_arrays(byte);
    mallopt(M_PERTURB, byte);
    SceneData d = prepare_scene(scene, 2);
    mallopt(M_PERTURB, 0);
    return d;
  };
  const SceneData a = build(0x5A);
  const SceneData b = build(0xA5);
  auto same_bytes = [](const auto& x, const auto& y, const char* what) {
    ASSERT_EQ(x.size(), y.size()) << what;
    EXPECT_EQ(std::memcmp(x.data(), y.data(), x.size() * sizeof(x[0])), 0) << what << " differ";
  };
  same_bytes(a.blas.nodes, b.blas.nodes, "bottom-level nodes");
  same_bytes(a.blas.tris, b.blas.tris, "triangles");
  same_bytes(a.wide_nodes, b.wide_nodes, "wide nodes");
  EXPECT_GT(a.blas.nodes.size() * sizeof(rf_node), kLargeArrayBytes) << "the nodes are not a large array";
  EXPECT_GT(a.wide_nodes.size() * sizeof(rf_wide_node), kLargeArrayBytes / 2) << "the wide nodes' reserve is not large";
}

// Neighbours in index order whose boxes are alike are built as one record
// (BuildOptions::pair_primitives), paired greedily: the halves of each quad
// of a grid (their boxes a quarter apart), which start at odd indices after
// a lone first box, share a leaf, side by side in the leaf order, while a
// neighbour that lies far away does not pair. The SAH counts a pair as two
// primitives: with leaves of at most 2, no leaf holds two pairs. The same
// boxes built unpaired split some quads, so the test tells the two builds
// apart.
TEST(Bvh, QuadHalvesPairAndFarNeighboursDoNot) {
  Rng rng(81);
  std::vector<Aabb> boxes;
  std::vector<char> far;  // per pair: its second half moved away
  auto flat = [](float x0, float y0, float x1, float y1, float z) {
    Aabb b;
    b.grow(glm::vec3(x0, y0, z));
    b.grow(glm::vec3(x1, y1, z));
    return b;
  };
  boxes.push_back(flat(-3.0f, -3.0f, -2.0f, -2.0f, 0.0f));  // alone: the quads start at odd indices
  for (int y = 0; y < 150; ++y)
    for (int x = 0; x < 150; ++x) {
      const bool moved = rng.below(5) == 0;
      boxes.push_back(flat(x, y, x + 1.0f, y + 1.0f, 0.0f));
      boxes.push_back(moved ? flat(x + 70.0f, y, x + 71.0f, y + 1.0f, 5.0f)
                            : flat(x + 0.25f, y, x + 1.25f, y + 1.0f, 0.0f));  // both: 1.25 times either
      far.push_back(moved);
    }
  BuildOptions opt;
  opt.max_leaf_size = 2;
  opt.intersection_cost = 0.01f;  // the SAH would rather make leaves as full as allowed
  // Quads whose halves share a leaf, side by side; checks every leaf's size.
  auto together = [&](const BuildTree& tree) {
    std::vector<uint32_t> leaf_of(boxes.size()), at(boxes.size());
    for (uint32_t k = 0; k < tree.nodes.size(); ++k) {
      const BuildNode& n = tree.nodes[k];
      if (!n.is_leaf()) continue;
      EXPECT_LE(n.count, opt.max_leaf_size) << "leaf " << k;
      for (uint32_t i = n.first; i < n.first + n.count; ++i) {
        leaf_of[tree.order[i]] = k;
        at[tree.order[i]] = i;
      }
    }
    std::vector<char> out(far.size());
    for (size_t p = 0; p < far.size(); ++p)
      out[p] = leaf_of[2 * p + 1] == leaf_of[2 * p + 2] && at[2 * p + 2] == at[2 * p + 1] + 1;
    return out;
  };
  for (unsigned threads : {1u, 2u}) {
    const BuildTree tree = build_sah(boxes, opt, threads);
    check_tree(tree, boxes);
    const std::vector<char> paired = together(tree);
    for (size_t p = 0; p < far.size(); ++p) EXPECT_EQ(paired[p], !far[p]) << "pair " << p << (far[p] ? " (far)" : "");
  }
  opt.pair_primitives = false;
  const BuildTree unpaired = build_sah(boxes, opt, 2);
  check_tree(unpaired, boxes);
  const std::vector<char> kept = together(unpaired);
  size_t split_quads = 0;
  for (size_t p = 0; p < far.size(); ++p) split_quads += !far[p] && !kept[p];
  EXPECT_GT(split_quads, far.size() / 10) << "the unpaired build keeps the quads together too";
}

// The flat layout at an odd and an even start: every pair on an even node
// index after its parent, every leaf's items once, each node's box the
// build node's. The same tree flattened in parallel is the same bytes.
TEST(Bvh, FlatTreeKeepsPairsAlignedAfterTheirParents) {
  Rng rng(79);
  const std::vector<Aabb> boxes = clustered_boxes(rng, 70000);
  const BuildTree tree = build_sah(boxes, BuildOptions{}, 2);
  for (uint32_t base : {0u, 1u, 6u}) {
    std::vector<rf_node> flat(3, rf_node{});
    flat.resize(base);
    const uint32_t root = flatten_bvh(tree, 100, nullptr, 0, flat);
    ASSERT_EQ(root, base);
    ASSERT_EQ(flat.size(), base + flat_node_count(tree, base));
    std::vector<int> items(tree.order.size(), 0);
    std::vector<uint32_t> stack{root};
    size_t visited = 0;
    while (!stack.empty()) {
      const uint32_t i = stack.back();
      stack.pop_back();
      ++visited;
      const rf_node& n = flat[i];
      if (n.meta > 0) {
        for (uint32_t k = n.first; k < n.first + n.meta; ++k) items.at(k - 100)++;
        continue;
      }
      ASSERT_EQ(n.first % 2, 0u) << "node " << i;
      ASSERT_GT(n.first, i) << "node " << i;
      for (uint32_t c : {n.first, n.first + 1}) {
        for (int k = 0; k < 3; ++k) {
          EXPECT_LE(n.bmin[k], flat[c].bmin[k]) << "node " << i;
          EXPECT_GE(n.bmax[k], flat[c].bmax[k]) << "node " << i;
        }
        stack.push_back(c);
      }
    }
    EXPECT_EQ(visited, tree.nodes.size());
    for (size_t k = 0; k < items.size(); ++k) ASSERT_EQ(items[k], 1) << "item " << k;
    std::vector<rf_node> parallel(flat_node_count(tree, base));
    flatten_bvh_at(tree, 100, nullptr, base, parallel.data(), 3);
    EXPECT_EQ(std::memcmp(parallel.data(), flat.data() + base, parallel.size() * sizeof(rf_node)), 0);
  }
}

// The split rules, checked node by node by brute force: every interior node
// splits at the cheapest boundary of 16 equal centre bins (8 for nodes of at
// most 32 primitives) over the three axes (first on ties, axes in order), or
// at the object median where no boundary separates anything; a node is a
// leaf exactly when it has one primitive or SAH prefers it and it fits.
TEST(Bvh, EverySplitIsTheCheapestBinOrSweepBoundary) {
  Rng rng(78);
  const std::vector<Aabb> boxes = clustered_boxes(rng, 40000);
  BuildOptions opt;
  opt.pair_primitives = false;  // one record a primitive, as the brute force splits (pairs: QuadHalvesPair...)
  const BuildTree tree = build_sah(boxes, opt, 2);
  check_tree(tree, boxes);
  size_t sah_splits = 0, sweeps = 0, medians = 0;
  // Each node's primitive range, recovered top-down.
  std::vector<std::pair<uint32_t, uint32_t>> range(tree.nodes.size());
  range[0] = {0, static_cast<uint32_t>(tree.order.size())};
  for (size_t i = 0; i < tree.nodes.size(); ++i) {
    const BuildNode& n = tree.nodes[i];
    if (n.is_leaf()) {
      EXPECT_EQ(range[i], std::make_pair(n.first, n.count)) << "node " << i;
      continue;
    }
    const BuildNode& l = tree.nodes[n.left];
    uint32_t left_count = l.count;
    if (!l.is_leaf()) {  // count the leaves below the left child
      left_count = 0;
      std::vector<uint32_t> stack{n.left};
      while (!stack.empty()) {
        const BuildNode& c = tree.nodes[stack.back()];
        stack.pop_back();
        if (c.is_leaf()) {
          left_count += c.count;
        } else {
          stack.push_back(c.left);
          stack.push_back(c.right);
        }
      }
    }
    range[n.left] = {range[i].first, left_count};
    range[n.right] = {range[i].first + left_count, range[i].second - left_count};
  }
  for (size_t i = 0; i < tree.nodes.size(); ++i) {
    const auto [first, count] = range[i];
    Aabb bounds, centres;
    for (uint32_t k = first; k < first + count; ++k) {
      bounds.grow(boxes[tree.order[k]]);
      centres.grow(boxes[tree.order[k]].centre());
    }
    const BuildNode& n = tree.nodes[i];
    for (int a = 0; a < 3; ++a) {
      ASSERT_EQ(n.bounds.lo[a], bounds.lo[a]) << "node " << i;
      ASSERT_EQ(n.bounds.hi[a], bounds.hi[a]) << "node " << i;
    }
    const int bins = count <= 32 ? std::min(opt.bins, 8) : opt.bins;  // the documented rule (BuildOptions::bins)
    auto bin_of = [&](const Aabb& b, int a) {
      const float f = (b.centre()[a] - centres.lo[a]) * (bins / (centres.hi[a] - centres.lo[a]));
      return !(f > 0.0f) ? 0 : f >= bins - 1 ? bins - 1 : static_cast<int>(f);
    };
    const float parent_area = std::max(bounds.half_area(), 1e-30f);
    if (count >= 2 && count <= opt.sweep_size) {
      // Every boundary of the primitives ordered by centre, ties by index.
      float best_sum = INFINITY;
      std::vector<uint32_t> best_left;
      for (int a = 0; a < 3; ++a) {
        std::vector<uint32_t> prims(tree.order.begin() + first, tree.order.begin() + first + count);
        std::sort(prims.begin(), prims.end(), [&](uint32_t p, uint32_t q) {
          const float cp = boxes[p].centre()[a], cq = boxes[q].centre()[a];
          return cp < cq || (cp == cq && p < q);
        });
        for (uint32_t j = 1; j < count; ++j) {
          Aabb left, right;
          for (uint32_t k = 0; k < count; ++k) (k < j ? left : right).grow(boxes[prims[k]]);
          const float sum =
              left.half_area() * static_cast<float>(j) + right.half_area() * static_cast<float>(count - j);
          if (sum < best_sum) {
            best_sum = sum;
            best_left.assign(prims.begin(), prims.begin() + j);
          }
        }
      }
      const float cost = opt.traversal_cost + opt.intersection_cost * best_sum / parent_area;
      const bool leaf = cost >= opt.intersection_cost * count && count <= opt.max_leaf_size;
      ASSERT_EQ(n.is_leaf(), leaf) << "node " << i << " of " << count << " primitives, best cost " << cost;
      if (leaf) continue;
      sweeps++;
      // As sets: the children's own splits reorder them.
      std::vector<uint32_t> left(tree.order.begin() + first, tree.order.begin() + first + range[n.left].second);
      std::sort(left.begin(), left.end());
      std::sort(best_left.begin(), best_left.end());
      ASSERT_EQ(left, best_left) << "node " << i << ": the left child is not the cheapest boundary's left side";
      continue;
    }
    // The bins: prices compare as area times count summed over both sides.
    float best = INFINITY;
    int best_axis = -1, best_bin = 0;
    for (int a = 0; a < 3; ++a) {
      if (!(centres.hi[a] > centres.lo[a])) continue;
      for (int b = 0; b + 1 < bins; ++b) {
        Aabb left, right;
        uint32_t nl = 0, nr = 0;
        for (uint32_t k = first; k < first + count; ++k) {
          const Aabb& box = boxes[tree.order[k]];
          if (bin_of(box, a) <= b) {
            left.grow(box);
            nl++;
          } else {
            right.grow(box);
            nr++;
          }
        }
        if (nl == 0 || nr == 0) continue;
        const float sum = left.half_area() * static_cast<float>(nl) + right.half_area() * static_cast<float>(nr);
        if (sum < best) {
          best = sum;
          best_axis = a;
          best_bin = b;
        }
      }
    }
    if (best_axis >= 0) best = opt.traversal_cost + opt.intersection_cost * best / parent_area;
    const bool prefers_leaf = best_axis < 0 || best >= opt.intersection_cost * count;
    const bool leaf = count <= 1 || (prefers_leaf && count <= opt.max_leaf_size);
    ASSERT_EQ(n.is_leaf(), leaf) << "node " << i << " of " << count << " primitives, best cost " << best;
    if (leaf) continue;
    const uint32_t left_count = range[n.left].second;
    if (best_axis >= 0) {
      sah_splits++;
      for (uint32_t k = first; k < first + count; ++k)
        ASSERT_EQ(bin_of(boxes[tree.order[k]], best_axis) <= best_bin, k < first + left_count)
            << "node " << i << " primitive " << tree.order[k] << " on the wrong side of axis " << best_axis << " bin "
            << best_bin;
    } else {
      medians++;
      EXPECT_EQ(left_count, count / 2) << "node " << i;
    }
  }
  EXPECT_GT(sah_splits, 1000u);
  EXPECT_GT(sweeps, 1000u);
  EXPECT_GT(medians, 10u);  // the dozens of duplicates
}

TEST(Bvh, TwoLevelTraversalEqualsBruteForce) {
  Rng rng(2024);
  int views = 0;
  for (int s = 0; s < 6; ++s) {
    const Scene scene = testing::random_scene(rng, 1 + rng.below(4), 1 + rng.below(12), 20 + rng.below(200));
    PipelineOptions opt;
    opt.backend = Backend::cpu;
    Pipeline renderer(scene, opt);
    for (int v = 0; v < 10; ++v, ++views) {
      const Camera cam = make_camera(testing::random_camera(rng, scene.world_bounds()), 48, 32);
      const RenderResult culled = renderer.render(cam);
      const std::vector<rf_pixel_hit> expected = testing::brute_force(scene, renderer.scene_data(), cam);
      EXPECT_EQ(testing::compare_hits(expected, culled.hits, cam.width), "") << "scene " << s << " view " << v;
      FrameOptions no_cull;
      no_cull.cull = false;
      const RenderResult unculled = renderer.render(cam, 1, no_cull);
      EXPECT_EQ(testing::compare_hits(expected, unculled.hits, cam.width), "") << "scene " << s << " view " << v;
    }
  }
  EXPECT_EQ(views, 60);
}

TEST(Bvh, SomethingIsHitInRandomViews) {
  // Guards the test above against passing on empty images.
  Rng rng(5);
  const Scene scene = testing::random_scene(rng, 2, 10, 300);
  PipelineOptions opt;
  opt.backend = Backend::cpu;
  Pipeline renderer(scene, opt);
  CameraSpec spec;
  spec.eye = glm::dvec3(0, 0, 20);
  spec.look_at = glm::dvec3(0, 0, 0);
  const RenderResult r = renderer.render(make_camera(spec, 64, 48));
  size_t hits = 0;
  for (const rf_pixel_hit& h : r.hits) hits += h.instance != RF_INVALID;
  EXPECT_GT(hits, 100u);
}

TEST(Bvh, MirroredInstanceKeepsFrontNormal) {
  // One triangle facing +z, instanced plainly and mirrored in x: both must
  // report the world normal (0, 0, 1), the front side glTF keeps under
  // mirroring node transforms.
  Scene scene;
  scene.meshes.push_back(testing::unit_triangle());
  scene.instances.push_back({0, glm::translate(Xform(1.0), glm::dvec3(-2, 0, 0)), "plain"});
  scene.instances.push_back(
      {0, glm::scale(glm::translate(Xform(1.0), glm::dvec3(2, 0, 0)), glm::dvec3(-1, 1, 1)), "mirrored"});
  PipelineOptions opt;
  opt.backend = Backend::cpu;
  Pipeline renderer(scene, opt);
  CameraSpec spec;
  spec.eye = glm::dvec3(0, 0, 10);
  spec.look_at = glm::dvec3(0, 0, 0);
  const Camera cam = make_camera(spec, 65, 33);
  const RenderResult r = renderer.render(cam);
  int seen[2] = {0, 0};
  for (const rf_pixel_hit& h : r.hits) {
    if (h.instance == RF_INVALID) continue;
    seen[h.instance]++;
    EXPECT_EQ(h.nx, 0.0f);
    EXPECT_EQ(h.ny, 0.0f);
    EXPECT_EQ(h.nz, 1.0f);
    EXPECT_NEAR(h.z, 10.0f * std::sqrt(1.0f + 0.0f), 1.0f);  // about 10 away
  }
  EXPECT_GT(seen[0], 10);
  EXPECT_GT(seen[1], 10);
}

TEST(Bvh, DistanceAndBarycentricsByHand) {
  // A big triangle at z = -5 in front of the eye at the origin: the centre
  // pixel of an odd image looks straight at it, distance exactly 5.
  Scene scene;
  Mesh tri;
  tri.positions = {{-10, -10, -5}, {10, -10, -5}, {0, 10, -5}};
  tri.indices = {0, 1, 2};
  scene.meshes.push_back(tri);
  scene.instances.push_back({0, Xform(1.0), "t"});
  PipelineOptions opt;
  opt.backend = Backend::cpu;
  Pipeline renderer(scene, opt);
  CameraSpec spec;  // eye at the origin looking down -z
  const Camera cam = make_camera(spec, 3, 3);
  const RenderResult r = renderer.render(cam);
  const rf_pixel_hit& c = r.hits[4];
  EXPECT_EQ(c.z, 5.0f);
  EXPECT_EQ(c.instance, 0u);
  EXPECT_EQ(c.primitive, 0u);
  // (0, 0) = 0.25 v0 + 0.25 v1 + 0.5 v2.
  EXPECT_FLOAT_EQ(c.u, 0.25f);
  EXPECT_FLOAT_EQ(c.v, 0.5f);
  EXPECT_EQ(c.nz, 1.0f);
}

TEST(Bvh, TieRulePicksLowerInstanceThenPrimitive) {
  // Two coincident copies of a two-triangle quad: every pixel is a tie in t
  // between instances 0 and 1; instance 0 must win. Within the quad, the
  // diagonal ties between primitives 0 and 1; primitive 0 must win there.
  Scene scene;
  Mesh quad;
  quad.positions = {{-1, -1, -3}, {1, -1, -3}, {1, 1, -3}, {-1, 1, -3}};
  quad.indices = {0, 1, 2, 0, 2, 3};
  scene.meshes.push_back(quad);
  scene.instances.push_back({0, Xform(1.0), "a"});
  scene.instances.push_back({0, Xform(1.0), "b"});
  PipelineOptions opt;
  opt.backend = Backend::cpu;
  Pipeline renderer(scene, opt);
  const Camera cam = make_camera(CameraSpec{}, 33, 33);
  const RenderResult r = renderer.render(cam);
  size_t hits = 0;
  for (const rf_pixel_hit& h : r.hits)
    if (h.instance != RF_INVALID) {
      EXPECT_EQ(h.instance, 0u);
      hits++;
    }
  EXPECT_GT(hits, 100u);
  // The centre pixel's ray goes through the diagonal exactly: primitive 0.
  EXPECT_EQ(r.hits[16 * 33 + 16].primitive, 0u);
}

}  // namespace
}  // namespace rayfold::core

namespace rayfold::core {
namespace {

// Re-braiding past the budget: a mesh whose triangles lie in two clusters
// far apart (one box, mostly empty) opens at its root; a compact mesh of as
// many triangles, whose halves' boxes together have more surface than the
// whole, stays one item. The budget alone opens neither.
TEST(Bvh, LooseNodesOpenPastTheBudget) {
  Scene s;
  Mesh spread = testing::closed_cube(2), compact = testing::closed_cube(2);
  const size_t n = spread.positions.size();
  for (size_t i = 0; i < n; ++i) spread.positions.push_back(spread.positions[i] + glm::vec3(50.0f, 0.0f, 0.0f));
  const size_t indices = spread.indices.size();
  for (size_t i = 0; i < indices; ++i) spread.indices.push_back(spread.indices[i] + static_cast<uint32_t>(n));
  for (size_t i = 0; i < indices; ++i) compact.indices.push_back(compact.indices[i]);  // each face twice
  s.meshes = {spread, compact};
  s.instances.resize(2);
  s.instances[0].mesh = 0;
  s.instances[1].mesh = 1;
  BraidOptions budget_only;
  budget_only.items_per_instance = 1;
  budget_only.min_items = 0;
  budget_only.loose_ratio = 0.0;
  MergeOptions apart;  // both at the identity: merged, they would be one tree
  apart.enabled = false;
  const SceneData closed = prepare_scene(s, 1, budget_only, apart);
  EXPECT_EQ(closed.braid_offsets[1] - closed.braid_offsets[0], 1u);
  EXPECT_EQ(closed.braid_offsets[2] - closed.braid_offsets[1], 1u);
  BraidOptions loose = budget_only;
  loose.loose_ratio = 1.0;
  const SceneData opened = prepare_scene(s, 1, loose, apart);
  EXPECT_GE(opened.braid_offsets[1] - opened.braid_offsets[0], 2u) << "the spread mesh's root opens";
  EXPECT_EQ(opened.braid_offsets[2] - opened.braid_offsets[1], 1u) << "the compact mesh stays whole";
  // Whatever the cut, the same bits: the traversal order does not matter.
  testing::Rng rng(5);
  for (int v = 0; v < 4; ++v) {
    const Camera cam = make_camera(testing::random_camera(rng, s.world_bounds()), 48, 32);
    PipelineOptions a, b;
    a.backend = b.backend = Backend::cpu;
    a.braid = budget_only;
    b.braid = loose;
    a.merge = b.merge = apart;
    EXPECT_EQ(testing::compare_hits(Pipeline(s, a).render(cam).hits, Pipeline(s, b).render(cam).hits, 48), "")
        << "view " << v;
  }
}

TEST(Bvh, MeshesWithinEightPowersOfTwoShareOneTreeSpace) {
  // Boxes whose largest coordinate has exponents 3, 2, -5 and -6, and an
  // empty one: the first three share the largest exponent, -6 lies 9 below
  // it and keeps its own, the empty box keeps 0. The choice moves with a
  // power-of-two scale of the scene.
  auto box = [](float big) {
    Aabb b;
    b.grow(glm::vec3(-0.5f * big, 0.0f, 0.25f * big));
    b.grow(glm::vec3(0.0f, big, 0.0f));
    return b;
  };
  for (int k : {0, 10, -20}) {
    const float s = std::ldexp(1.0f, k);
    const std::vector<Aabb> bounds = {box(12.0f * s), box(5.0f * s), box(0.04f * s), box(0.02f * s), Aabb{}};
    std::vector<int> exponents;
    choose_tree_exponents(bounds, exponents);
    EXPECT_EQ(exponents, (std::vector<int>{3 + k, 3 + k, 3 + k, -6 + k, 0})) << "scale 2^" << k;
  }
}

// Boxes whose areas are not numbers (an infinite extent beside a zero one,
// as a query frame's top level makes of instances beyond the float range)
// price no sweep boundary: the node is split at the object median as when
// no bin separates anything, and every primitive still sits in one leaf
// once. (The sweep's order was left unwritten and its primitives read from
// wherever it pointed; and their centres, infinity minus infinity, ranked
// two records alike: found by the fuzzer through a ray query.)
TEST(Bvh, BoxesOfNoAreaAreSplitAtTheMedianKeepingEveryPrimitive) {
  for (size_t n : {size_t{2}, size_t{3}, size_t{4}, size_t{9}, size_t{40}}) {
    std::vector<Aabb> boxes(n);
    for (size_t i = 0; i < n; ++i) {
      boxes[i].grow(glm::vec3(-INFINITY, float(i), 0.0f));
      boxes[i].grow(glm::vec3(INFINITY, float(i), 0.0f));
    }
    BuildOptions o;
    o.max_leaf_size = 1;
    const BuildTree tree = build_sah(boxes, o);
    std::vector<uint32_t> seen;
    for (const BuildNode& node : tree.nodes)
      if (node.is_leaf())
        for (uint32_t k = node.first; k < node.first + node.count; ++k) seen.push_back(tree.order.at(k));
    std::sort(seen.begin(), seen.end());
    std::vector<uint32_t> all(n);
    std::iota(all.begin(), all.end(), 0u);
    EXPECT_EQ(seen, all) << n << " boxes";
  }
}

// The wide trees hold the binary trees' leaves, boxes and ranges (what makes
// the tile and query kernels' hits the CPU reference's): below every entry,
// each binary leaf under it once, with its own box; two to `width` children
// per node, the slots in use first; every child's box inside the binary box
// it was collapsed from; an entry inside another's subtree collapsed once.
template <class Trees>
void expect_wide_trees_keep_the_binary_leaves(
    Trees (*collapse)(const rf_node*, size_t, const std::vector<uint32_t>&)) {
  using WideNode = typename decltype(Trees::nodes)::value_type;
  constexpr int width = static_cast<int>(sizeof(WideNode::child) / sizeof(WideNode::child[0]));
  Rng rng(83);
  size_t full_nodes = 0;
  for (int n : {1, 2, 5, 3000}) {
    const std::vector<Aabb> boxes = clustered_boxes(rng, n);
    std::vector<rf_node> nodes;
    const uint32_t root = flatten_bvh(build_sah(boxes), 0, nullptr, 0, nodes);
    // The root, every node of one random path down, and the nodes where
    // two more random paths stop.
    std::vector<uint32_t> entries = {root};
    for (uint32_t x = root; (nodes[x].meta & RF_NODE_COUNT_MASK) == 0;) {
      x = nodes[x].first + static_cast<uint32_t>(rng.below(2));
      entries.push_back(x);
    }
    for (int walk = 0; walk < 2; ++walk) {
      uint32_t x = root;
      for (int steps = rng.below(12); steps > 0 && (nodes[x].meta & RF_NODE_COUNT_MASK) == 0; --steps)
        x = nodes[x].first + static_cast<uint32_t>(rng.below(2));
      entries.push_back(x);
    }
    const Trees wide = collapse(nodes.data(), nodes.size(), entries);
    ASSERT_EQ(wide.roots.size(), entries.size());
    auto binary_leaves = [&](uint32_t x) {
      std::vector<uint32_t> out, todo = {x};
      while (!todo.empty()) {
        const uint32_t y = todo.back();
        todo.pop_back();
        if (nodes[y].meta & RF_NODE_COUNT_MASK)
          out.push_back(y);
        else
          todo.insert(todo.end(), {nodes[y].first, nodes[y].first + 1});
      }
      return out;
    };
    for (size_t e = 0; e < entries.size(); ++e) {
      const rf_node& entry = nodes[entries[e]];
      if (entry.meta & RF_NODE_COUNT_MASK) {
        EXPECT_EQ(wide.roots[e], RF_INVALID) << "leaf entry " << entries[e];
        continue;
      }
      ASSERT_LT(wide.roots[e], wide.nodes.size());
      // Leaves reached through the wide nodes, as (first triangle, count, box).
      std::multiset<std::vector<float>> got, want;
      std::vector<std::pair<uint32_t, rf_node>> todo = {{wide.roots[e], entry}};
      while (!todo.empty()) {
        const auto [w, parent] = todo.back();
        todo.pop_back();
        ASSERT_LT(w, wide.nodes.size());
        const WideNode& wn = wide.nodes[w];
        int used = 0;
        while (used < width && wn.count[used] != RF_INVALID) ++used;
        EXPECT_GE(used, 2) << "wide node " << w;
        full_nodes += used == width;
        for (int k = used; k < width; ++k) EXPECT_EQ(wn.count[k], RF_INVALID) << "wide node " << w << " slot " << k;
        for (int k = 0; k < used; ++k) {
          const float lo[3] = {wn.lo_x[k], wn.lo_y[k], wn.lo_z[k]}, hi[3] = {wn.hi_x[k], wn.hi_y[k], wn.hi_z[k]};
          for (int a = 0; a < 3; ++a) {
            EXPECT_GE(lo[a], parent.bmin[a]) << "wide node " << w << " slot " << k;
            EXPECT_LE(hi[a], parent.bmax[a]) << "wide node " << w << " slot " << k;
          }
          rf_node as_binary{{lo[0], lo[1], lo[2]}, wn.child[k], {hi[0], hi[1], hi[2]}, wn.count[k]};
          if (wn.count[k] != 0)
            got.insert({float(wn.child[k]), float(wn.count[k]), lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]});
          else
            todo.push_back({wn.child[k], as_binary});
        }
      }
      for (uint32_t leaf : binary_leaves(entries[e])) {
        const rf_node& l = nodes[leaf];
        want.insert({float(l.first), float(l.meta), l.bmin[0], l.bmin[1], l.bmin[2], l.bmax[0], l.bmax[1], l.bmax[2]});
      }
      EXPECT_EQ(got, want) << "entry " << entries[e] << " of " << n << " boxes";
    }
    // Collapsed once: every entry lies below the root, so every wide node is
    // reached from the root's, and only once.
    if (wide.roots[0] != RF_INVALID) {
      std::vector<int> seen(wide.nodes.size(), 0);
      std::vector<uint32_t> todo = {wide.roots[0]};
      while (!todo.empty()) {
        const uint32_t w = todo.back();
        todo.pop_back();
        ++seen[w];
        for (int k = 0; k < width; ++k)
          if (wide.nodes[w].count[k] == 0) todo.push_back(wide.nodes[w].child[k]);
      }
      for (size_t w = 0; w < seen.size(); ++w) EXPECT_EQ(seen[w], 1) << "wide node " << w << " of " << n << " boxes";
    }
  }
  EXPECT_GT(full_nodes, 100u) << "nodes with all " << width << " slots in use: too few for the test to mean anything";
}

TEST(Bvh, WideTreesKeepTheBinaryLeavesBelowEveryEntry) { expect_wide_trees_keep_the_binary_leaves(build_wide_trees); }

TEST(Bvh, EightWideTreesKeepTheBinaryLeavesBelowEveryEntry) {
  expect_wide_trees_keep_the_binary_leaves(build_wide8_trees);
}

// The 8-wide trees are the collapse of least summed surface area over the
// binary nodes that become wide nodes (a scattered ray steps into a node
// with a chance that goes with its area), each holding at most eight
// slots and every entry one of its own: against a brute force over every
// set of binary nodes on small trees, with and without entries inside
// (listed before and after the root: the costs are made children first
// whatever the entries' order).
TEST(Bvh, EightWideTreesHaveTheLeastSummedAreaOfAnyCollapse) {
  Rng rng(97);
  auto half_area = [](const float lo[3], const float hi[3]) {
    const float dx = hi[0] - lo[0], dy = hi[1] - lo[1], dz = hi[2] - lo[2];
    return dx * dy + dy * dz + dz * dx;
  };
  int trees = 0, opened_below_top = 0;
  for (int attempt = 0; attempt < 400 && trees < 60; ++attempt) {
    const std::vector<Aabb> boxes = clustered_boxes(rng, 9 + static_cast<int>(rng.below(40)));
    std::vector<rf_node> nodes;
    const uint32_t root = flatten_bvh(build_sah(boxes), 0, nullptr, 0, nodes);
    std::vector<uint32_t> interior;
    for (std::vector<uint32_t> todo = {root}; !todo.empty();) {
      const uint32_t x = todo.back();
      todo.pop_back();
      if (nodes[x].meta & RF_NODE_COUNT_MASK) continue;
      interior.push_back(x);
      todo.insert(todo.end(), {nodes[x].first, nodes[x].first + 1});
    }
    // Ten leaves or more (a root that cannot hold them all), few enough to
    // enumerate.
    if (interior.size() < 9 || interior.size() > 17) continue;
    ++trees;
    // Entries inside the root's tree, listed after it, before it, or two
    // of them (one may lie inside the other).
    std::vector<uint32_t> entries = {root};
    const auto inner = [&] { return interior[1 + rng.below(interior.size() - 1)]; };
    if (trees % 4 == 1) entries.push_back(inner());
    if (trees % 4 == 2) entries.insert(entries.begin(), inner());
    if (trees % 4 == 3) entries = {inner(), root, inner()};
    // Brute force: every set of interior nodes that holds the entries.
    double best = INFINITY;
    for (uint32_t mask = 0; mask < (1u << (interior.size() - 1)); ++mask) {
      std::vector<bool> wide(nodes.size(), false);
      wide[root] = true;
      for (size_t i = 1; i < interior.size(); ++i) wide[interior[i]] = (mask >> (i - 1)) & 1u;
      bool ok = true;
      for (uint32_t e : entries) ok = ok && wide[e];
      double area = 0.0;
      for (uint32_t w : interior) {
        if (!ok || !wide[w]) continue;
        int slots = 0;
        for (std::vector<uint32_t> todo = {nodes[w].first, nodes[w].first + 1}; !todo.empty();) {
          const uint32_t y = todo.back();
          todo.pop_back();
          if ((nodes[y].meta & RF_NODE_COUNT_MASK) || wide[y])
            ++slots;
          else
            todo.insert(todo.end(), {nodes[y].first, nodes[y].first + 1});
        }
        ok = slots <= 8;
        area += half_area(nodes[w].bmin, nodes[w].bmax);
      }
      if (ok) best = std::min(best, area);
    }
    const Wide8Trees wide = build_wide8_trees(nodes.data(), nodes.size(), entries);
    double got = 0.0;
    for (const rf_wide8_node& w : wide.nodes) {
      float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
      for (int k = 0; k < 8 && w.count[k] != RF_INVALID; ++k) {
        lo[0] = std::min(lo[0], w.lo_x[k]);
        lo[1] = std::min(lo[1], w.lo_y[k]);
        lo[2] = std::min(lo[2], w.lo_z[k]);
        hi[0] = std::max(hi[0], w.hi_x[k]);
        hi[1] = std::max(hi[1], w.hi_y[k]);
        hi[2] = std::max(hi[2], w.hi_z[k]);
      }
      got += half_area(lo, hi);
    }
    EXPECT_NEAR(got, best, 1e-5 * best) << "tree " << trees << ": " << boxes.size() << " boxes, " << interior.size()
                                        << " interior nodes, " << entries.size() << " entries, " << wide.nodes.size()
                                        << " wide nodes";
    opened_below_top += wide.nodes.size() > entries.size();
  }
  EXPECT_GE(trees, 40) << "too few small trees for the test to mean anything";
  EXPECT_GT(opened_below_top, trees / 4) << "too few trees with wide nodes below their entries";
}

// A mesh of dense_triangles or more is built with the dense leaf cost:
// fewer nodes, fuller leaves (BuildOptions); the meshes beside it keep
// theirs. Its tile and single-ray renders still give the CPU reference's
// bits, and the brute force's.
TEST(Bvh, DenseMeshesGetFullerLeaves) {
  Rng rng(5150);
  Scene scene = testing::random_scene(rng, 2, 3, 300);
  {  // a bumpy grid of 2^17 triangles
    Mesh dense;
    const int n = 256;
    for (int y = 0; y <= n; ++y)
      for (int x = 0; x <= n; ++x)
        dense.positions.push_back(
            {x / 64.0f - 2.0f, y / 64.0f - 2.0f, 0.05f * std::sin(0.7f * x) * std::cos(0.3f * y)});
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const uint32_t a = y * (n + 1) + x, b = a + 1, c = a + n + 1, d = c + 1;
        dense.indices.insert(dense.indices.end(), {a, b, d, a, d, c});
      }
    ASSERT_EQ(dense.triangle_count(), BuildOptions{}.dense_triangles);
    scene.meshes.push_back(dense);
    Instance inst;
    inst.mesh = static_cast<uint32_t>(scene.meshes.size() - 1);
    inst.world_from_object = Xform(1.0);
    scene.instances.push_back(inst);
  }
  BuildOptions plain;
  plain.dense_triangles = SIZE_MAX;
  const BlasSet dense = build_blas_set(scene, BuildOptions{}, 2), sparse = build_blas_set(scene, plain, 2);
  const auto nodes = [](const BlasSet& s, size_t m) {  // under mesh m's root
    size_t count = 0;
    std::vector<uint32_t> todo{s.roots[m]};
    while (!todo.empty()) {
      const rf_node& n = s.nodes[todo.back()];
      todo.pop_back();
      ++count;
      if ((n.meta & RF_NODE_COUNT_MASK) == 0) todo.insert(todo.end(), {n.first, n.first + 1});
    }
    return count;
  };
  const size_t last = scene.meshes.size() - 1;
  EXPECT_LT(nodes(dense, last), nodes(sparse, last) * 3 / 4)
      << nodes(dense, last) << " against " << nodes(sparse, last);
  for (size_t m = 0; m < last; ++m) EXPECT_EQ(nodes(dense, m), nodes(sparse, m)) << "mesh " << m;
  const Camera cam = make_camera(testing::random_camera(rng, scene.world_bounds()), 64, 40);
  PipelineOptions opt;
  opt.backend = Backend::cpu;
  Pipeline cpu(scene, opt);
  const HitBuffer want = cpu.render(cam).hits;
  EXPECT_EQ(testing::compare_hits(testing::brute_force(scene, cpu.scene_data(), cam), want, cam.width), "");
  for (Kernel k : {Kernel::tile, Kernel::single}) {
    opt.backend = Backend::opencl;
    opt.kernel = k;
    Pipeline cl(scene, opt);
    EXPECT_EQ(testing::compare_hits(want, cl.render(cam).hits, cam.width), "") << "kernel " << int(k);
  }
}

}  // namespace
}  // namespace rayfold::core
