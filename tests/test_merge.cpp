// Static instances of one transform traced through one tree (bvh/blas.h):
// every member's triangles there once, with its id; the hits of brute force
// over the instances one by one in every tracer and fold; the tie rule across
// members; dynamic instances and --animate kept apart.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <set>
#include <utility>

#include "bvh/scene_data.h"
#include "bvh/scene_file.h"
#include "pipeline/pipeline.h"
#include "scene/animation.h"
#include "test_util.h"

namespace rayfold::core {
namespace {

// random_scene's soups, most of them sharing one of two transforms: the
// instances i % 3 != 2 take instance (i % 2)'s, so they form the groups
// {0, 4, 6, 10, ...} and {1, 3, 7, 9, ...}; the others keep their own.
Scene shared_transform_scene(uint64_t seed, int instances) {
  testing::Rng rng(seed);
  Scene s = testing::random_scene(rng, 5, instances, 60);
  for (size_t i = 2; i < s.instances.size(); ++i)
    if (i % 3 != 2) s.instances[i].world_from_object = s.instances[i % 2].world_from_object;
  return s;
}

uint32_t expected_first(size_t i) { return i % 3 != 2 ? static_cast<uint32_t>(i % 2) : static_cast<uint32_t>(i); }

// Every triangle below a node, as (scene instance, primitive) for a tree
// traced by instance `first`.
std::vector<std::pair<uint32_t, uint32_t>> tree_triangles(const BlasSet& blas, uint32_t root, uint32_t first) {
  std::vector<std::pair<uint32_t, uint32_t>> out;
  std::vector<uint32_t> stack{root};
  while (!stack.empty()) {
    const rf_node& n = blas.nodes[stack.back()];
    stack.pop_back();
    if (n.meta != 0) {
      for (uint32_t k = 0; k < n.meta; ++k)
        out.push_back({first + blas.tris[n.first + k].inst, blas.tris[n.first + k].prim});
      continue;
    }
    stack.push_back(n.first);
    stack.push_back(n.first + 1);
  }
  std::sort(out.begin(), out.end());
  return out;
}

TEST(Merge, EachGroupsTreeHoldsEveryMembersTrianglesOnce) {
  const Scene s = shared_transform_scene(3, 14);
  const SceneData data = prepare_scene(s, 2);
  const BlasSet& blas = data.blas;
  for (size_t i = 0; i < s.instances.size(); ++i) {
    EXPECT_EQ(blas.traced_by[i], expected_first(i)) << "instance " << i;
    EXPECT_EQ(blas.merged[i], i % 3 != 2) << "instance " << i;
    const bool traces = blas.traced_by[i] == i;
    EXPECT_EQ(blas.instance_roots[i] != RF_INVALID, traces) << "instance " << i;
    EXPECT_EQ(data.braid_offsets[i + 1] > data.braid_offsets[i], traces)
        << "only the first member enters the top level";
    EXPECT_TRUE(data.renderable[i]);
  }
  for (uint32_t first : {0u, 1u}) {
    std::vector<std::pair<uint32_t, uint32_t>> want;
    for (size_t i = 0; i < s.instances.size(); ++i)
      if (expected_first(i) == first)
        for (uint32_t t = 0; t < s.meshes[s.instances[i].mesh].triangle_count(); ++t)
          want.push_back({static_cast<uint32_t>(i), t});
    EXPECT_EQ(tree_triangles(blas, blas.instance_roots[first], first), want) << "group of " << first;
  }
  // A lone instance keeps its mesh's own tree, whose triangles add nothing.
  EXPECT_EQ(blas.instance_roots[2], blas.roots[s.instances[2].mesh]);
  for (const auto& [inst, prim] : tree_triangles(blas, blas.instance_roots[2], 2)) EXPECT_EQ(inst, 2u);

  // Dynamic instances, and no merging at all, keep the meshes' trees.
  MergeOptions merge;
  merge.dynamic.assign(5, 0);
  merge.dynamic[4] = 1;
  const BlasSet some = prepare_scene(s, 2, {}, merge).blas;
  EXPECT_FALSE(some.merged[4]);
  EXPECT_EQ(some.instance_roots[4], some.roots[s.instances[4].mesh]);
  EXPECT_TRUE(some.merged[6]);
  merge.enabled = false;
  const BlasSet none = prepare_scene(s, 2, {}, merge).blas;
  for (size_t i = 0; i < s.instances.size(); ++i) {
    EXPECT_FALSE(none.merged[i]);
    EXPECT_EQ(none.instance_roots[i], none.roots[s.instances[i].mesh]);
  }
}

TEST(Merge, MergedTreesGiveBruteForceHitsInEveryTracerAndFold) {
  testing::Rng rng(11);
  for (uint64_t seed : {5u, 6u}) {
    const Scene s = shared_transform_scene(seed, 12);
    testing::ThreeWays r(s);
    ASSERT_TRUE(r.cpu->scene_data().blas.merged[0]);
    for (int v = 0; v < 3; ++v) {
      const Camera cam = make_camera(testing::random_camera(rng, s.world_bounds()), 45, 31);
      EXPECT_EQ(testing::compare_hits(testing::brute_force(s, r.cpu->scene_data(), cam), r.reference(cam), 45), "")
          << "seed " << seed << " view " << v;
      EXPECT_EQ(r.differences(cam), "") << "seed " << seed << " view " << v;
    }
  }
}

// Merged trees through scene-file bytes (Scene::save): the same bits, in
// the tile kernel too, and the merge's lists as written.
TEST(Merge, SceneFilesKeepMergedTreesAndTheirBits) {
  const Scene s = shared_transform_scene(4, 10);
  const SceneData data = prepare_scene(s, 2);
  ASSERT_TRUE(data.blas.merged[0]);
  const std::string bytes = scene_file_bytes(SceneFile{s, data, "", {}}, "test");
  const SceneFile back = read_scene_file(bytes.data(), bytes.size(), "merged.rfscene", "test");
  EXPECT_EQ(back.data.blas.traced_by, data.blas.traced_by);
  EXPECT_EQ(back.data.blas.instance_roots, data.blas.instance_roots);
  EXPECT_EQ(back.data.blas.merged, data.blas.merged);
  testing::Rng rng(3);
  const Camera cam = make_camera(testing::random_camera(rng, s.world_bounds()), 41, 27);
  PipelineOptions o;
  o.backend = Backend::cpu;
  const HitBuffer want = Pipeline(s, o).render(cam).hits;
  o.backend = Backend::opencl;
  o.kernel = Kernel::tile;
  Pipeline loaded(back.scene, o, std::make_shared<const SceneData>(back.data));
  EXPECT_EQ(testing::compare_hits(want, loaded.render(cam).hits, 41), "");
}

// Ray queries through merged trees: the single-ray kernel enters a group's
// whole tree once (FrameOptions::whole_trees) and each hit names its member
// (rf_tri::inst), the query tile kernel and the CPU reference the re-braided
// cuts: every field the same bits, scattered rays and rays of one origin.
TEST(Merge, RayQueriesThroughMergedTreesGiveTheReferencesBits) {
  const Scene s = shared_transform_scene(6, 12);
  testing::Rng rng(12);
  const Aabb b = s.world_bounds();
  std::vector<float> o, d;
  for (int i = 0; i < 6000; ++i)
    for (int k = 0; k < 3; ++k) {
      o.push_back(i < 3000 ? rng.uniformf(b.lo[k], b.hi[k]) : 0.5f * (b.lo[k] + b.hi[k]));
      d.push_back(rng.uniformf(-1.0f, 1.0f));
    }
  const size_t n = o.size() / 3;
  PipelineOptions opt;
  opt.backend = Backend::cpu;
  Pipeline cpu(s, opt);
  ASSERT_TRUE(cpu.scene_data().blas.merged[0]);
  std::vector<rf_pixel_hit> want(n), got(n);
  cpu.intersect(o.data(), d.data(), n, 0.0f, INFINITY, false, FrameOptions{}, want.data());
  const BlasSet& blas = cpu.scene_data().blas;
  size_t members = 0;
  for (const rf_pixel_hit& h : want) members += h.instance != RF_INVALID && blas.traced_by[h.instance] != h.instance;
  EXPECT_GT(members, n / 100) << "too few hits on the groups' later members for the test to mean anything";
  opt.backend = Backend::opencl;
  for (const Kernel kernel : {Kernel::single, Kernel::tile}) {
    opt.kernel = kernel;
    Pipeline cl(s, opt);
    cl.intersect(o.data(), d.data(), n, 0.0f, INFINITY, false, FrameOptions{}, got.data());
    size_t differ = 0;
    for (size_t i = 0; i < n; ++i) differ += std::memcmp(&want[i], &got[i], sizeof(rf_pixel_hit)) != 0;
    EXPECT_EQ(differ, 0u) << "kernel " << int(kernel);
  }
}

// Two copies of one cube at one place, and a third instance between their
// ids elsewhere: the copies share a tree, and every pixel of the cube is the
// lower copy's (the tie rule: equal t, the lower instance id), in every
// tracer and fold.
TEST(Merge, CoincidentCopiesResolveToTheLowerInstance) {
  Scene s;
  s.meshes = {testing::closed_cube(3), testing::closed_cube(2)};
  s.instances.resize(3);
  s.instances[0].mesh = 0;
  s.instances[1].mesh = 1;
  s.instances[1].world_from_object[3] = glm::dvec4(0.0, 0.0, -20.0, 1.0);
  s.instances[2].mesh = 0;
  testing::ThreeWays r(s);
  const BlasSet& blas = r.cpu->scene_data().blas;
  ASSERT_TRUE(blas.merged[0] && blas.merged[2] && !blas.merged[1]);
  CameraSpec spec;
  spec.eye = glm::dvec3(0.7, 0.9, 4.0);
  spec.look_at = glm::dvec3(0.0, 0.0, 0.0);
  spec.vfov_degrees = 50.0;
  const Camera cam = make_camera(spec, 40, 30);
  const HitBuffer ref = r.reference(cam);
  size_t cube = 0;
  for (const rf_pixel_hit& h : ref) {
    if (h.instance == RF_INVALID) continue;
    EXPECT_EQ(h.instance, 0u);
    ++cube;
  }
  EXPECT_GT(cube, ref.size() / 4) << "the cube fills the middle of the view";
  EXPECT_EQ(r.differences(cam), "");
}

// --animate moves every fourth instance: built dynamic, the moving ones keep
// their meshes' trees, the rest still merge, and every frame has the bits
// of the CPU reference.
TEST(Merge, AnimatedInstancesAreBuiltApart) {
  const Scene s = shared_transform_scene(8, 12);
  PipelineOptions o;
  o.backend = Backend::cpu;
  o.merge.dynamic = animated_instances(s.instances.size());
  Pipeline cpu(s, o);
  const BlasSet& blas = cpu.scene_data().blas;
  for (size_t i = 0; i < s.instances.size(); ++i)
    if (is_animated(i)) {
      EXPECT_FALSE(blas.merged[i]) << "instance " << i;
    }
  EXPECT_TRUE(blas.merged[0] && blas.merged[4]);
  o.backend = Backend::opencl;
  o.kernel = Kernel::tile;
  Pipeline tile(s, o);
  testing::Rng rng(2);
  const Camera cam = make_camera(testing::random_camera(rng, s.world_bounds()), 40, 28);
  for (int frame = 0; frame < 3; ++frame) {
    FrameOptions f;
    f.animate_frame = frame;
    f.fold = Fold::xy;
    FrameOptions none = f;
    none.fold = Fold::none;
    EXPECT_EQ(testing::compare_hits(cpu.render(cam, 1, none).hits, tile.render(cam, 1, f).hits, 40), "")
        << "frame " << frame;
  }
}

}  // namespace
}  // namespace rayfold::core
