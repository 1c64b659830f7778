// Ray queries (Pipeline::intersect): rays from anywhere against brute force
// in floats (the same test and tie rule, bit for bit) and in doubles, the
// OpenCL kernel against the CPU reference, the interval and occlusion
// rules, scaling by powers of two, and bad rays.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>

#include <glm/gtc/matrix_transform.hpp>

#include "rayfold/errors.h"
#include "rays/ray_order.h"
#include "rays/ray_queries.h"
#include "rf_trace.h"
#include "test_util.h"
#include "util/span.h"

namespace rayfold::core {
namespace {

using testing::Rng;

struct Rays {
  std::vector<float> o, d;
  size_t size() const { return o.size() / 3; }
};

// Origins inside the bounds (some inside objects) and a little beyond;
// half the directions toward a random point of a random instance's
// triangle, the others anywhere, a tenth of those along an axis; lengths
// from 1e-3 to 1e3. With runs, consecutive rays in runs of those lengths
// share an origin (the rest of the rays one each).
Rays random_rays(Rng& rng, const Scene& scene, size_t n, const std::vector<size_t>& runs = {}) {
  Rays r;
  const Aabb b = scene.world_bounds();
  const glm::vec3 e = b.extent();
  size_t run = 0, left = 0;
  for (size_t i = 0; i < n; ++i) {
    if (left > 0 && --left > 0) {
      for (int k = 0; k < 3; ++k) r.o.push_back(r.o[3 * (i - 1) + k]);
    } else {
      left = run < runs.size() ? runs[run++] : 1;
      for (int k = 0; k < 3; ++k) r.o.push_back(rng.uniformf(b.lo[k] - 0.2f * e[k], b.hi[k] + 0.2f * e[k]));
    }
    float d[3];
    do {
      for (float& c : d) c = rng.uniformf(-1.0f, 1.0f);
    } while (d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < 1e-4f);
    const Instance& inst = scene.instances[rng.below(static_cast<int>(scene.instances.size()))];
    const Mesh& mesh = scene.meshes[inst.mesh];
    if (rng.below(2) == 0 && mesh.triangle_count() > 0) {
      const size_t t = static_cast<size_t>(rng.below(static_cast<int>(mesh.triangle_count())));
      const float a = rng.uniformf(0.0f, 1.0f), c = rng.uniformf(0.0f, 1.0f - a);
      const glm::dvec3 p = glm::dvec3(mesh.positions[mesh.indices[3 * t]]) * double(1 - a - c) +
                           glm::dvec3(mesh.positions[mesh.indices[3 * t + 1]]) * double(a) +
                           glm::dvec3(mesh.positions[mesh.indices[3 * t + 2]]) * double(c);
      const glm::dvec3 w = glm::dvec3(inst.world_from_object * glm::dvec4(p, 1.0));
      for (int k = 0; k < 3; ++k) d[k] = static_cast<float>(w[k] - r.o[3 * i + k]);
    } else if (rng.below(5) == 0) {
      const int axis = rng.below(3);
      for (int k = 0; k < 3; ++k) d[k] = k == axis ? (rng.below(2) ? 1.0f : -1.0f) : 0.0f;
    }
    const float len = std::exp2(rng.uniformf(-10.0f, 10.0f));
    for (float c : d) r.d.push_back(c * len);
  }
  return r;
}

// Default options on `backend`.
PipelineOptions on(Backend backend) {
  PipelineOptions opt;
  opt.backend = backend;
  return opt;
}

std::vector<rf_pixel_hit> query(Pipeline& r, const Rays& rays, float tmin = 0.0f, float tmax = INFINITY,
                                bool any_hit = false) {
  std::vector<rf_pixel_hit> out(rays.size());
  r.intersect(rays.o.data(), rays.d.data(), rays.size(), tmin, tmax, any_hit, FrameOptions{}, out.data());
  return out;
}

// "" when every field is the same bits; else the first difference and the count.
std::string differences(ConstSpan<rf_pixel_hit> a, ConstSpan<rf_pixel_hit> b) {
  size_t count = 0;
  std::string first;
  for (size_t i = 0; i < a.size(); ++i) {
    const rf_pixel_hit x = a[i], y = b[i];
    if (std::memcmp(&x, &y, sizeof x) == 0) continue;
    if (count++ == 0) {
      char buf[240];
      std::snprintf(buf, sizeof buf,
                    "ray %zu: (%u, %u, t %.9g, u %.9g, v %.9g) against (%u, %u, t %.9g, u %.9g, v %.9g)", i, x.instance,
                    x.primitive, x.z, x.u, x.v, y.instance, y.primitive, y.z, y.u, y.v);
      first = buf;
    }
  }
  return count ? first + " (" + std::to_string(count) + " rays differ)" : "";
}

TEST(RayQuery, EqualsBruteForceBitForBitOnRandomScenes) {
  Rng rng(4711);
  size_t hits = 0, rays_total = 0;
  for (int s = 0; s < 6; ++s) {
    const Scene scene = testing::random_scene(rng, 1 + rng.below(4), 1 + rng.below(12), 20 + rng.below(200));
    PipelineOptions opt;
    opt.backend = Backend::cpu;
    Pipeline renderer(scene, opt);
    const Rays rays = random_rays(rng, scene, 3000);
    const std::vector<rf_pixel_hit> got = query(renderer, rays);
    const std::vector<rf_pixel_hit> expected = testing::brute_force_rays(scene, renderer.scene_data(), rays.o.data(),
                                                                         rays.d.data(), rays.size(), 0.0f, INFINITY);
    EXPECT_EQ(differences(expected, got), "") << "scene " << s;
    for (const rf_pixel_hit& h : got) hits += h.instance != RF_INVALID;
    rays_total += rays.size();
  }
  EXPECT_GT(hits, rays_total / 10) << "too few rays hit for the test to mean anything";
}

// The CPU reference against the OpenCL kernel on the same rays: every
// field the same bits; for occlusion, which answers whether a hit exists,
// the same answers (the kernel walks the 8-wide trees and stops at its
// first hit, another than the reference's first), at two tmax, and some
// rays occluded and some not.
void expect_kernel_equals_reference(Pipeline& cpu, Pipeline& cl, const Rays& rays, const std::string& what) {
  EXPECT_EQ(differences(query(cpu, rays), query(cl, rays)), "") << what;
  for (const float tmax : {INFINITY, 0.5f}) {
    const std::vector<rf_pixel_hit> want = query(cpu, rays, 0.0f, tmax, true), got = query(cl, rays, 0.0f, tmax, true);
    size_t differ = 0, occluded = 0;
    for (size_t i = 0; i < rays.size(); ++i) {
      differ += (want[i].instance != RF_INVALID) != (got[i].instance != RF_INVALID);
      occluded += want[i].instance != RF_INVALID;
    }
    EXPECT_EQ(differ, 0u) << what << ", occlusion to " << tmax;
    EXPECT_GT(occluded, rays.size() / 20) << what << ", occlusion to " << tmax;
    EXPECT_LT(occluded, rays.size()) << what << ", occlusion to " << tmax;
  }
}

TEST(RayQuery, OpenClKernelEqualsTheCpuReference) {
  Rng rng(99);
  for (int s = 0; s < 4; ++s) {
    const Scene scene = testing::random_scene(rng, 1 + rng.below(4), 1 + rng.below(12), 20 + rng.below(300));
    Pipeline cpu(scene, on(Backend::cpu)), cl(scene, on(Backend::opencl));
    expect_kernel_equals_reference(cpu, cl, random_rays(rng, scene, 5000), "scene " + std::to_string(s));
  }
}

// The query trees live beside the scene's device buffers: a render that
// needs larger buffers uploads the scene again, and the next query must
// find its trees there again (the trees themselves are made once).
TEST(RayQuery, QueriesAfterALargerRenderEqualTheCpuReference) {
  Rng rng(123);
  const Scene scene = testing::random_scene(rng, 2, 6, 200);
  Pipeline cpu(scene, on(Backend::cpu)), cl(scene, on(Backend::opencl));
  const Rays rays = random_rays(rng, scene, 3000);
  expect_kernel_equals_reference(cpu, cl, rays, "before the render");
  auto hits_bytes = [&] {
    for (const BufferInfo& b : cl.device_buffers())
      if (b.name == "hits") return b.bytes;
    return size_t{0};
  };
  const size_t before = hits_bytes();
  const Camera cam = make_camera(testing::random_camera(rng, scene.world_bounds()), 640, 480);
  cl.render(cam);
  ASSERT_GT(hits_bytes(), before) << "the render did not upload the scene again into larger buffers";
  expect_kernel_equals_reference(cpu, cl, rays, "after the render");
}

// A few instances over one another make a top level of one leaf, which
// the single-ray kernel enters without its box (rf_trace_query_tlas_wide):
// every instance of the leaf is traced, mirrored ones included.
TEST(RayQuery, ATopLevelOfOneLeafTracesEveryInstanceInIt) {
  Rng rng(2024);
  Scene scene = testing::random_scene(rng, 1, 3, 300);
  Aabb box;
  for (const glm::vec3& p : scene.meshes[0].positions) box.grow(p);
  for (glm::vec3& p : scene.meshes[0].positions) p -= 0.5f * (box.lo + box.hi);
  // About the same box each: the mesh as it is, mirrored in x, and turned
  // a quarter about y.
  scene.instances[0].world_from_object = Xform(1.0);
  scene.instances[1].world_from_object = glm::scale(Xform(1.0), glm::dvec3(-1.0, 1.0, 1.0));
  scene.instances[2].world_from_object = glm::rotate(Xform(1.0), 1.5707963267948966, glm::dvec3(0.0, 1.0, 0.0));
  Pipeline cpu(scene, on(Backend::cpu)), cl(scene, on(Backend::opencl));
  const Rays rays = random_rays(rng, scene, 5000);
  const SceneData& data = cl.scene_data();
  const Wide8Trees trees = build_query_trees(data);
  const Frame frame = build_query_frame(
      scene, data, check_query_rays(rays.o.data(), rays.d.data(), rays.size(), 0.0f, INFINITY), FrameOptions{}, &trees);
  ASSERT_EQ(frame.tlas_wide_root, RF_INVALID) << "the top level is not one leaf";
  ASSERT_EQ(frame.tlas_nodes.at(frame.tlas_root - frame.node_base).first >> RF_TLAS_COUNT_SHIFT, 3u);
  expect_kernel_equals_reference(cpu, cl, rays, "three instances in one leaf");
}

// Scattered rays among hundreds of instances, a third of them mirrored:
// the single-ray kernel walks the query frame's top level and each
// instance's whole tree in 8-wide nodes (rf_trace_query_tlas_wide), the CPU
// reference the re-braided cuts in binary ones.
TEST(RayQuery, ManyInstancesThroughTheWideTopLevelEqualTheCpuReference) {
  Rng rng(7);
  const Scene scene = testing::random_scene(rng, 3, 300, 40);
  Pipeline cpu(scene, on(Backend::cpu)), cl(scene, on(Backend::opencl));
  const Rays rays = random_rays(rng, scene, 6000);
  const SceneData& data = cl.scene_data();
  const float bound = check_query_rays(rays.o.data(), rays.d.data(), rays.size(), 0.0f, INFINITY);
  const Wide8Trees trees = build_query_trees(data);
  const Frame frame = build_query_frame(scene, data, bound, FrameOptions{}, &trees);
  ASSERT_GT(frame.tlas_wide.size(), 10u) << "the top level the kernel walks";
  // One item per traced tree, each with its whole tree's 8-wide root.
  size_t trees_traced = 0;
  for (uint32_t root : data.blas.instance_roots) trees_traced += root != RF_INVALID;
  EXPECT_EQ(frame.instances.size(), trees_traced);
  ASSERT_EQ(frame.query_wide_roots.size(), frame.instances.size());
  for (size_t k = 0; k < frame.instances.size(); ++k) {
    const rf_instance& inst = frame.instances[k];
    EXPECT_EQ(inst.blas_root, data.blas.instance_roots[inst.instance_id]) << "item " << k;
    EXPECT_EQ(frame.query_wide_roots[k], trees.roots[inst.instance_id]) << "item " << k;
  }
  // The re-braided frame (the tile kernel's, the reference's) enters more
  // cuts than that.
  EXPECT_GT(build_query_frame(scene, data, bound, FrameOptions{}).instances.size(), trees_traced);
  expect_kernel_equals_reference(cpu, cl, rays, "300 instances");
}

// A cloud of 2^17 small triangles is built as a dense mesh (fuller leaves,
// BuildOptions::dense_triangles), in clusters of 1 to 8 about one point that
// no split separates, and the single-ray kernel tests the triangles of a
// leaf of three or more eight at a time (rf_trace_leaf_wide): every slot of
// the eight, in leaves of every size, gives the CPU reference's bits.
// (Mutation-checked: dropping the eighth slot's triangle fails it; the
// random scenes above hold no leaf of more than six.)
TEST(RayQuery, LeavesTestedEightTrianglesAtATimeEqualTheCpuReference) {
  Rng rng(808);
  Mesh mesh;
  for (uint32_t t = 0; t < (1u << 17);) {
    const glm::vec3 c(rng.uniformf(0, 1), rng.uniformf(0, 1), rng.uniformf(0, 1));
    const float r = rng.uniformf(0.001f, 0.005f);
    for (int cluster = 1 + rng.below(8); cluster > 0; --cluster, ++t) {
      for (int k = 0; k < 3; ++k)
        mesh.positions.push_back(c + r * glm::vec3(rng.uniformf(-1, 1), rng.uniformf(-1, 1), rng.uniformf(-1, 1)));
      mesh.indices.insert(mesh.indices.end(), {3 * t, 3 * t + 1, 3 * t + 2});
    }
  }
  Scene scene;
  scene.meshes.push_back(mesh);
  scene.instances.emplace_back();
  scene.instances[0].mesh = 0;
  Pipeline cpu(scene, on(Backend::cpu)), cl(scene, on(Backend::opencl));
  size_t sizes[9] = {};
  for (const rf_node& n : cl.scene_data().blas.nodes) {
    const uint32_t count = n.meta & RF_NODE_COUNT_MASK;
    if (count != 0) sizes[std::min<uint32_t>(count, 8)]++;
  }
  for (int count = 3; count <= 8; ++count)
    EXPECT_GT(sizes[count], 100u) << "leaves of " << count << " triangles: too few for the test to mean anything";
  expect_kernel_equals_reference(cpu, cl, random_rays(rng, scene, 20000), "a cloud of 2^17 triangles");
}

// Rays that graze a tilted triangle and hit it just inside the edge that
// lies on its box's x = min face, coming through that face: the hit is
// where the ray enters the leaf's box, and the triangle test's t, off by
// about the rounding over the sine of the angle (1e-6 to 6e-5 here), falls
// before the box's entry for some of them (94 of about 2300 hits), which
// raises it to the entry of the leaf it was found in (rf_hit_distance). The single-ray
// kernel walks the 8-wide trees, the CPU reference the binary ones: the
// same bits only if each hit takes its own leaf's entry, not an ancestor's.
// Upright triangles above the tilted ones give the nodes above the leaves
// larger boxes. (Given an ancestor's entry instead, 18 to 43 of these rays
// differ; the random scenes above found no difference.)
TEST(RayQuery, GrazingHitsTakeTheirOwnLeafsEntryThroughTheWideTrees) {
  Rng rng(31);
  Mesh mesh;
  struct Tilt {
    glm::vec3 a;
    float ab, ac;  // the rise of the edges along x and along y
  };
  std::vector<Tilt> tilted;
  for (int k = 0; k < 64; ++k) {
    const Tilt t{{k % 4 * 2.5f, k / 4 % 4 * 2.5f, k / 16 * 2.5f}, rng.uniformf(0.1f, 0.6f), rng.uniformf(0.1f, 0.6f)};
    const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(),
                          {t.a, t.a + glm::vec3(2.0f, 0.0f, 2.0f * t.ab), t.a + glm::vec3(0.0f, 2.0f, 2.0f * t.ac)});
    mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2});
    tilted.push_back(t);
  }
  for (int k = 0; k < 12; ++k) {
    const glm::vec3 p{rng.uniformf(0.0f, 10.0f), rng.uniformf(0.0f, 10.0f), 12.0f};
    const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(), {p, p + glm::vec3(0.2f, 0.0f, 0.0f), p + glm::vec3(0.0f, 0.1f, 4.0f)});
    mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2});
  }
  Scene scene;
  scene.meshes.push_back(mesh);
  scene.instances.emplace_back();
  scene.instances[0].mesh = 0;

  Rays rays;
  for (int i = 0; i < 4000; ++i) {
    const Tilt& t = tilted[rng.below(static_cast<int>(tilted.size()))];
    const float s = rng.uniformf(0.05f, 0.95f), inside = rng.uniformf(0.0f, 1e-5f);
    const glm::vec3 hit = t.a + glm::vec3(inside, 2.0f * s, inside * t.ab + 2.0f * s * t.ac);
    const glm::vec3 along = glm::normalize(glm::vec3(1.0f, 0.0f, t.ab));
    const glm::vec3 normal = glm::normalize(glm::vec3(-t.ab, -t.ac, 1.0f));
    const glm::vec3 d = glm::normalize(along - std::exp2(rng.uniformf(-20.0f, -14.0f)) * normal);
    const glm::vec3 o = hit - rng.uniformf(0.25f, 1.0f) * d;
    rays.o.insert(rays.o.end(), {o.x, o.y, o.z});
    rays.d.insert(rays.d.end(), {d.x, d.y, d.z});
  }
  Pipeline cpu(scene, on(Backend::cpu)), cl(scene, on(Backend::opencl));
  const std::vector<rf_pixel_hit> expected = query(cpu, rays), got = query(cl, rays);
  EXPECT_EQ(differences(expected, got), "");
  size_t hits = 0;
  for (const rf_pixel_hit& h : expected) hits += h.instance != RF_INVALID;
  EXPECT_GT(hits, rays.size() / 2) << hits << " rays hit: too few for the test to mean anything";
  // The premise: some hits are raised to their leaf's entry, above the
  // triangle test's own t (the brute force's, which knows no leaves), and
  // none lies below it.
  const std::vector<rf_pixel_hit> raw =
      testing::brute_force_rays(scene, cpu.scene_data(), rays.o.data(), rays.d.data(), rays.size(), 0.0f, INFINITY);
  size_t raised = 0, lowered = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    if (expected[i].instance == RF_INVALID || expected[i].instance != raw[i].instance ||
        expected[i].primitive != raw[i].primitive)
      continue;
    raised += expected[i].z > raw[i].z;
    lowered += expected[i].z < raw[i].z;
  }
  EXPECT_GT(raised, rays.size() / 100) << raised << " hits raised to their leaf's entry: the rays do not graze enough";
  EXPECT_EQ(lowered, 0u);
}

// Rays in runs that share an origin (a camera's, a sensor's, a light's) go
// through the query tile kernel in vector lanes: every field the CPU
// reference's bits and the single-ray kernel's, with tmin and tmax, for
// runs that are not whole tiles; occlusion the same answers.
TEST(RayQuery, SharedOriginTilesEqualTheCpuReference) {
  Rng rng(2024);
  for (int s = 0; s < 4; ++s) {
    const Scene scene = testing::random_scene(rng, 1 + rng.below(4), 1 + rng.below(12), 20 + rng.below(300));
    // Runs of 1000, 700, 3000 (eleven tiles and a part) and 300 rays from
    // one origin each.
    const Rays rays = random_rays(rng, scene, 5000, {1000, 700, 3000, 300});
    PipelineOptions opt;
    opt.backend = Backend::cpu;
    Pipeline cpu(scene, opt);
    opt.backend = Backend::opencl;
    opt.kernel = Kernel::tile;
    Pipeline tiles(scene, opt);
    opt.kernel = Kernel::single;
    Pipeline single(scene, opt);
    ASSERT_EQ(plan_query_tiles(rays.o.data(), rays.size(), 0, 128).tiles.size(), 1 + 4 + 3 + 12 + 2)
        << "the runs as tiles";
    const float tmin = 0.0f, tmax = INFINITY;
    for (auto [lo, hi] : {std::pair{tmin, tmax}, std::pair{0.5f, tmax}, std::pair{0.0f, 2.0f}}) {
      const std::vector<rf_pixel_hit> want = query(cpu, rays, lo, hi);
      size_t hits = 0;
      for (const rf_pixel_hit& h : want) hits += h.instance != RF_INVALID;
      EXPECT_GT(hits, rays.size() / 20) << "scene " << s;
      EXPECT_EQ(differences(want, query(tiles, rays, lo, hi)), "") << "scene " << s << " tmin " << lo << " tmax " << hi;
      EXPECT_EQ(differences(want, query(single, rays, lo, hi)), "") << "scene " << s;
      // Occlusion answers whether a hit exists: the tiles find the closest
      // where the single ray stops at its first.
      const std::vector<rf_pixel_hit> any = query(cpu, rays, lo, hi, true), tiled = query(tiles, rays, lo, hi, true);
      size_t differ = 0;
      for (size_t i = 0; i < rays.size(); ++i)
        differ += (any[i].instance != RF_INVALID) != (tiled[i].instance != RF_INVALID);
      EXPECT_EQ(differ, 0u) << "scene " << s << ", occlusion";
    }
  }
  // Rays from many origins are not tiled.
  std::vector<float> scattered(3000, 0.0f);
  for (size_t i = 0; i < 1000; ++i) scattered[3 * i] = static_cast<float>(i);
  EXPECT_TRUE(plan_query_tiles(scattered.data(), 1000, 0, 128).tiles.empty());
}

// The query tile kernel reads the caller's world-space arrays and takes
// them to trace space itself (rf_pow2_scale), as to_trace_space does for
// the CPU reference: the same bits at every scale, where 2^e is a normal
// float (a product) and where it is not (ldexp), with tmin and tmax, in
// runs of one origin, and as an image in blocks whose left and right halves
// have origins of their own (a tile's origin read through the order).
TEST(RayQuery, TilesTakeTheCallersArraysToTraceSpaceAsTheReferenceDoes) {
  Rng rng(4242);
  const Scene base = testing::random_scene(rng, 3, 8, 150);
  const Rays runs = random_rays(rng, base, 3000, {1000, 700, 1300});
  const Aabb b = base.world_bounds();
  // 4 x 2 blocks of 16 x 16, the first column's from another eye: a tile's
  // first traced ray is image ray 256 t, in the first column, so the tile
  // reads its origin through the order or from the wrong eye.
  const size_t width = 64, height = 32;
  Rays image;
  for (size_t y = 0; y < height; ++y)
    for (size_t x = 0; x < width; ++x) {
      const float side = x < 16 ? 0.3f : 0.7f;
      const glm::vec3 eye = b.lo + glm::vec3(side, 0.5f, 2.0f) * b.extent();
      image.o.insert(image.o.end(), {eye.x, eye.y, eye.z});
      image.d.insert(image.d.end(), {(x + 0.5f) / width - 0.5f, 0.5f - (y + 0.5f) / height, -1.5f});
    }
  const QueryTiles plan = plan_query_tiles(image.o.data(), image.size(), width, 128);
  ASSERT_FALSE(plan.tiles.empty() || plan.order.empty()) << "the image in blocks";
  ASSERT_EQ(plan.tiles.size(), 1u + 8) << "one tile a block";
  bool by_product = false, by_ldexp = false;
  for (int k : {-132, -60, 0, 50, 100})
    for (const auto& [unscaled, row_length] : {std::pair<const Rays*, size_t>{&runs, 0}, {&image, width}}) {
      Scene scene = base;
      for (Instance& inst : scene.instances) inst.world_from_object = uniform_scale(k) * inst.world_from_object;
      Rays rays = *unscaled;
      for (float& c : rays.o) c = std::ldexp(c, k);
      for (float& c : rays.d) c = std::ldexp(c, k);
      PipelineOptions opt = on(Backend::cpu);
      Pipeline cpu(scene, opt);
      opt.backend = Backend::opencl;
      opt.kernel = Kernel::tile;
      Pipeline tiles(scene, opt);
      ASSERT_FALSE(plan_query_tiles(rays.o.data(), rays.size(), row_length, 128).tiles.empty())
          << "2^" << k << ": not tiled";
      const int e = -build_query_frame(scene, cpu.scene_data(),
                                       check_query_rays(rays.o.data(), rays.d.data(), rays.size(), 0.0f, INFINITY),
                                       FrameOptions{})
                         .views.at(0)
                         .trace_exponent;
      (e > -126 && e < 126 ? by_product : by_ldexp) = true;
      // t is along the given direction: scaling both keeps it.
      for (auto [lo, hi] : {std::pair{0.0f, INFINITY}, std::pair{0.5f, INFINITY}, std::pair{0.0f, 2.0f}}) {
        const std::vector<rf_pixel_hit> want = query(cpu, rays, lo, hi);
        size_t hits = 0;
        for (const rf_pixel_hit& h : want) hits += h.instance != RF_INVALID;
        if (hi == INFINITY || row_length == 0) {  // the image lies beyond t = 2
          EXPECT_GT(hits, rays.size() / 20) << "2^" << k;
        }
        std::vector<rf_pixel_hit> got(rays.size());
        tiles.intersect(rays.o.data(), rays.d.data(), rays.size(), lo, hi, false, FrameOptions{}, got.data(),
                        row_length);
        EXPECT_EQ(differences(want, got), "")
            << "2^" << k << ", trace from world 2^" << e << ", rows of " << row_length;
      }
    }
  EXPECT_TRUE(by_product && by_ldexp) << "both ways of scaling";
}

// Rays from many origins are traced one by one in the order of their
// origins' cells (a 16^3 grid over their box, in Morton order) and their
// directions' octants: every ray once, keys never decreasing, ties in input
// order, one order on any thread count; fewer than kMinOrderedRays keep the
// input order. The answers' independence of the order is
// AnswersDoNotDependOnOrderOrBatching's, their bits OpenClKernelEquals-
// TheCpuReference's (both take this order for their scattered rays).
TEST(RayQuery, ScatteredRaysGoInCellAndOctantOrder) {
  // By hand: in the box (0, 0, 0) to (16, 16, 16) the origin
  // (3.5, 0.5, 15.9) lies in cell (3, 0, 15), Morton 0b1001 | 0 << 1 |
  // 0b1001001001 << 2 = 0x92d; the direction (-1, 2, -0) is in octant
  // 1 | 4 (x and z have their sign bits set).
  const float lo[3] = {0.0f, 0.0f, 0.0f}, hi[3] = {16.0f, 16.0f, 16.0f};
  const float origin[3] = {3.5f, 0.5f, 15.9f}, direction[3] = {-1.0f, 2.0f, -0.0f};
  EXPECT_EQ(scattered_ray_key(origin, direction, lo, hi), (0x92du << 3) | 5u);
  const float outside[3] = {-1.0f, 17.0f, 16.0f};  // clamped to the edge cells
  EXPECT_EQ(scattered_ray_key(outside, direction, lo, hi), ((0x492u | 0x924u) << 3) | 5u);
  const float nan_origin[3] = {NAN, 17.0f, 16.0f};  // a defined cell, not a float-to-int of NaN
  EXPECT_EQ(scattered_ray_key(nan_origin, direction, lo, hi), ((0x492u | 0x924u) << 3) | 5u);

  Rng rng(31);
  const size_t n = 5001;  // parts of unequal length on 3 threads
  std::vector<float> o(3 * n), d(3 * n);
  for (size_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) {
      // Few distinct origins, so that many rays share a key.
      o[3 * i + a] = static_cast<float>(rng.below(6)) * 4.0f - 10.0f;
      d[3 * i + a] = rng.uniformf(-1.0f, 1.0f);
    }
  std::vector<uint32_t> one, two, three;
  scattered_ray_order(o.data(), d.data(), n, one, 1);
  scattered_ray_order(o.data(), d.data(), n, two, 2);
  scattered_ray_order(o.data(), d.data(), n, three, 3);
  EXPECT_EQ(one, two) << "the order on 1 and 2 threads";
  EXPECT_EQ(one, three) << "the order on 1 and 3 threads";
  ASSERT_EQ(one.size(), n);
  std::vector<uint32_t> sorted = one;
  std::sort(sorted.begin(), sorted.end());
  for (size_t i = 0; i < n; ++i) ASSERT_EQ(sorted[i], i) << "a permutation";
  float blo[3] = {o[0], o[1], o[2]}, bhi[3] = {o[0], o[1], o[2]};
  for (size_t i = 0; i < n; ++i)
    for (int a = 0; a < 3; ++a) {
      blo[a] = std::min(blo[a], o[3 * i + a]);
      bhi[a] = std::max(bhi[a], o[3 * i + a]);
    }
  const auto key = [&](uint32_t i) { return scattered_ray_key(&o[3 * i], &d[3 * i], blo, bhi); };
  size_t ties = 0;
  for (size_t k = 1; k < n; ++k) {
    const uint32_t a = key(one[k - 1]), b = key(one[k]);
    ASSERT_LE(a, b) << "keys at " << k;
    if (a == b) {
      ++ties;
      ASSERT_LT(one[k - 1], one[k]) << "ties in input order at " << k;
    }
  }
  EXPECT_GT(ties, n / 2) << "too few ties for the test to mean anything";
  scattered_ray_order(o.data(), d.data(), kMinOrderedRays - 1, one, 2);
  EXPECT_TRUE(one.empty()) << "few rays keep the input order";
}

// An image's rays (rows of row_length, one origin) go in 16x16 blocks, the
// edge blocks partial, each ray once; the answers are the CPU reference's
// bits whatever the blocks, and the same without row_length.
TEST(RayQuery, ImageRaysInBlocksEqualTheCpuReference) {
  Rng rng(77);
  const Scene scene = testing::random_scene(rng, 3, 10, 200);
  const Aabb b = scene.world_bounds();
  const glm::vec3 eye = b.lo + 0.5f * b.extent() + glm::vec3(0.0f, 0.0f, 1.5f * b.extent().z);
  const int width = 70, height = 37;  // neither a multiple of 16
  // A camera's rays from eye, rows of `width`.
  const auto image_rays = [&](int rows) {
    Rays r;
    for (int y = 0; y < rows; ++y)
      for (int x = 0; x < width; ++x) {
        r.o.insert(r.o.end(), {eye.x, eye.y, eye.z});
        r.d.insert(r.d.end(), {(x + 0.5f) / width - 0.5f, 0.5f - (y + 0.5f) / rows, -2.5f});
      }
    return r;
  };
  const Rays rays = image_rays(height);
  const QueryTiles plan = plan_query_tiles(rays.o.data(), rays.size(), width, 128);
  ASSERT_EQ(plan.tiles.size(), 1u + 3 * 5) << "3 block rows of 5 blocks";
  std::vector<uint32_t> sorted = plan.order;
  std::sort(sorted.begin(), sorted.end());
  for (size_t i = 0; i < sorted.size(); ++i) ASSERT_EQ(sorted[i], i) << "a permutation";
  EXPECT_EQ(plan.order[4], static_cast<uint32_t>(width)) << "the first 4x4 quad's second row";
  EXPECT_EQ(plan.order[16], 4u) << "the quad to its right";
  EXPECT_TRUE(plan_query_tiles(rays.o.data(), rays.size() - 1, width, 128).order.empty()) << "not whole rows";
  // A kept plan gives a fresh plan's tiles and order, whatever size came before.
  QueryTiles kept;
  for (size_t rows : {size_t{37}, size_t{20}, size_t{37}, size_t{20}, size_t{9}, size_t{37}, size_t{9}}) {
    plan_query_tiles(rays.o.data(), rows * width, width, 128, kept);
    const QueryTiles fresh = plan_query_tiles(rays.o.data(), rows * width, width, 128);
    EXPECT_EQ(kept.tiles, fresh.tiles) << rows << " rows";
    EXPECT_EQ(kept.traced_order(), fresh.order) << rows << " rows";
  }
  PipelineOptions opt;
  opt.backend = Backend::cpu;
  Pipeline cpu(scene, opt);
  opt.backend = Backend::opencl;
  opt.kernel = Kernel::tile;
  Pipeline tiles(scene, opt);
  const std::vector<rf_pixel_hit> want = query(cpu, rays);
  size_t hits = 0;
  for (const rf_pixel_hit& h : want) hits += h.instance != RF_INVALID;
  EXPECT_GT(hits, rays.size() / 4);
  std::vector<rf_pixel_hit> got(rays.size());
  tiles.intersect(rays.o.data(), rays.d.data(), rays.size(), 0.0f, INFINITY, false, FrameOptions{}, got.data(), width);
  EXPECT_EQ(differences(want, got), "") << "in blocks";
  EXPECT_EQ(differences(want, query(tiles, rays)), "") << "in rows";
  // An image's chunks are whole bands of 16 rows.
  EXPECT_EQ(query_chunk_rays(1280) % (16 * 1280), 0u);
  EXPECT_EQ(query_chunk_rays(0), size_t{1} << 20);
  // An image of more than one chunk, its last one shorter: each chunk's
  // blocks and answers in their places.
  const int tall = static_cast<int>(query_chunk_rays(width) / width) + 100;
  const Rays image = image_rays(tall);
  const std::vector<rf_pixel_hit> want_image = query(cpu, image);
  std::vector<rf_pixel_hit> got_image(image.size());
  tiles.intersect(image.o.data(), image.d.data(), image.size(), 0.0f, INFINITY, false, FrameOptions{}, got_image.data(),
                  width);
  EXPECT_EQ(differences(want_image, got_image), "") << "an image of " << tall << " rows in chunks";
}

// The exact (double) hit of the same float ray on every triangle in world
// space: rayfold's triangle is the closest on all but near ties, its t
// within a few float roundings.
TEST(RayQuery, AgreesWithADoubleReference) {
  Rng rng(321);
  const Scene scene = testing::random_scene(rng, 3, 8, 200);
  PipelineOptions opt;
  opt.backend = Backend::cpu;
  Pipeline renderer(scene, opt);
  const Rays rays = random_rays(rng, scene, 4000);
  const std::vector<rf_pixel_hit> got = query(renderer, rays);
  size_t both = 0, same = 0, close = 0;
  for (size_t q = 0; q < rays.size(); ++q) {
    const glm::dvec3 o(rays.o[3 * q], rays.o[3 * q + 1], rays.o[3 * q + 2]);
    const glm::dvec3 d(rays.d[3 * q], rays.d[3 * q + 1], rays.d[3 * q + 2]);
    double best = INFINITY;
    uint32_t bi = RF_INVALID, bp = RF_INVALID;
    for (size_t i = 0; i < scene.instances.size(); ++i) {
      const Mesh& mesh = scene.meshes[scene.instances[i].mesh];
      const Xform& w = scene.instances[i].world_from_object;
      for (size_t t = 0; t < mesh.triangle_count(); ++t) {
        glm::dvec3 v[3];
        for (int k = 0; k < 3; ++k)
          v[k] = glm::dvec3(w * glm::dvec4(glm::dvec3(mesh.positions[mesh.indices[3 * t + k]]), 1.0));
        const glm::dvec3 e1 = v[1] - v[0], e2 = v[2] - v[0], p = glm::cross(d, e2);
        const double det = glm::dot(e1, p);
        if (det == 0.0) continue;
        const glm::dvec3 s = o - v[0];
        const double u = glm::dot(s, p) / det;
        const glm::dvec3 qv = glm::cross(s, e1);
        const double vv = glm::dot(d, qv) / det, th = glm::dot(e2, qv) / det;
        if (u < 0 || vv < 0 || u + vv > 1 || !(th > 0) || th >= best) continue;
        best = th;
        bi = static_cast<uint32_t>(i);
        bp = static_cast<uint32_t>(t);
      }
    }
    if (bi == RF_INVALID || got[q].instance == RF_INVALID) continue;
    ++both;
    if (got[q].instance != bi || got[q].primitive != bp) continue;
    ++same;
    close += std::fabs(got[q].z - best) <= 1e-4 * best;
  }
  ASSERT_GT(both, 500u);
  EXPECT_GE(same, both * 99 / 100) << same << " of " << both << " rays on the double reference's triangle";
  EXPECT_GE(close, same * 999 / 1000) << close << " of " << same << " within 1e-4 of the double t";
}

// One square at z = -5 facing +z, rays from the origin down -z.
Scene square_at_minus_five() {
  Scene scene;
  Mesh m;
  m.positions = {{-1, -1, -5}, {1, -1, -5}, {1, 1, -5}, {-1, 1, -5}};
  m.indices = {0, 1, 2, 0, 2, 3};
  scene.meshes.push_back(m);
  Instance inst;
  inst.mesh = 0;
  scene.instances.push_back(inst);
  return scene;
}

TEST(RayQuery, IntervalAndOcclusionRules) {
  const Scene scene = square_at_minus_five();
  for (Backend b : {Backend::cpu, Backend::opencl}) {
    PipelineOptions opt;
    opt.backend = b;
    Pipeline r(scene, opt);
    const Rays unit{{0.25f, 0.125f, 0.0f}, {0.0f, 0.0f, -1.0f}};
    const Rays twice{{0.25f, 0.125f, 0.0f}, {0.0f, 0.0f, -2.0f}};
    EXPECT_EQ(query(r, unit)[0].z, 5.0f);
    EXPECT_EQ(query(r, twice)[0].z, 2.5f) << "t is along the direction as given";
    EXPECT_EQ(query(r, unit, 0.0f, 5.0f)[0].z, 5.0f) << "tmax is included";
    EXPECT_EQ(query(r, unit, 0.0f, 4.99f)[0].instance, RF_INVALID);
    EXPECT_EQ(query(r, unit, 5.0f)[0].instance, RF_INVALID) << "tmin is excluded";
    EXPECT_EQ(query(r, unit, 4.99f)[0].z, 5.0f);
    EXPECT_EQ(query(r, unit, 0.0f, 4.99f, true)[0].instance, RF_INVALID);
    EXPECT_NE(query(r, unit, 0.0f, INFINITY, true)[0].instance, RF_INVALID);
    // Any finite length: t scales with it exactly (5 / 2^k).
    for (float len : {0x1p-120f, 0x1p-60f, 0x1p60f, 0x1p126f}) {
      const Rays scaled{{0.25f, 0.125f, 0.0f}, {0.0f, 0.0f, -len}};
      EXPECT_EQ(query(r, scaled)[0].z, 5.0f / len) << "direction length " << len;
      EXPECT_EQ(query(r, scaled, 0.0f, 4.0f / len)[0].instance, RF_INVALID) << "direction length " << len;
    }
    const rf_pixel_hit h = query(r, unit)[0];
    EXPECT_EQ(h.nz, 1.0f) << "the G-buffer's normal";
    const Rays away{{0.25f, 0.125f, 0.0f}, {0.0f, 0.0f, 1.0f}};
    EXPECT_EQ(query(r, away)[0].z, INFINITY);
    EXPECT_EQ(query(r, away)[0].primitive, RF_INVALID);
  }
}

TEST(RayQuery, TheFastBuildRefusesQueries) {
  // Its finite-math assumptions do not hold for query bounds and
  // axis-aligned rays: it missed this hit with tmax = inf and crashed on
  // others. A clear error instead.
  PipelineOptions opt;
  opt.backend = Backend::opencl;
  opt.precision = KernelPrecision::fast;
  Pipeline r(square_at_minus_five(), opt);
  const Rays unit{{0.25f, 0.125f, 0.0f}, {0.0f, 0.0f, -1.0f}};
  try {
    query(r, unit);
    ADD_FAILURE() << "the fast build answered a query";
  } catch (const rayfold::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("exact build only"), std::string::npos) << e.what();
  }
}

TEST(RayQuery, ScalingSceneAndRaysByPowersOfTwoKeepsEveryBit) {
  Rng rng(17);
  const Scene scene = testing::random_scene(rng, 2, 6, 150);
  const Rays rays = random_rays(rng, scene, 2000);
  PipelineOptions opt;
  opt.backend = Backend::cpu;
  Pipeline base(scene, opt);
  const std::vector<rf_pixel_hit> expected = query(base, rays);
  for (int k : {-40, -3, 5, 60}) {
    Scene scaled = scene;
    for (Instance& inst : scaled.instances) inst.world_from_object = uniform_scale(k) * inst.world_from_object;
    Rays r = rays;
    for (float& c : r.o) c = std::ldexp(c, k);
    for (float& c : r.d) c = std::ldexp(c, k);
    Pipeline renderer(scaled, opt);
    EXPECT_EQ(differences(expected, query(renderer, r)), "") << "2^" << k;
  }
}

TEST(RayQuery, AnswersDoNotDependOnOrderOrBatching) {
  Rng rng(5);
  const Scene scene = testing::random_scene(rng, 3, 10, 200);
  PipelineOptions opt;
  opt.backend = Backend::opencl;
  Pipeline r(scene, opt);
  const Rays rays = random_rays(rng, scene, 3000);
  const std::vector<rf_pixel_hit> all = query(r, rays);
  std::vector<size_t> order(rays.size());
  std::iota(order.begin(), order.end(), 0);
  std::reverse(order.begin(), order.end());
  Rays reversed;
  for (size_t i : order) {
    reversed.o.insert(reversed.o.end(), rays.o.begin() + 3 * i, rays.o.begin() + 3 * i + 3);
    reversed.d.insert(reversed.d.end(), rays.d.begin() + 3 * i, rays.d.begin() + 3 * i + 3);
  }
  const std::vector<rf_pixel_hit> back = query(r, reversed);
  std::vector<rf_pixel_hit> unreversed(rays.size());
  for (size_t k = 0; k < order.size(); ++k) unreversed[order[k]] = back[k];
  EXPECT_EQ(differences(all, unreversed), "");
  // The first 10 rays alone: another top level (its box padding follows the
  // batch's origins), the same answers.
  Rays ten{{rays.o.begin(), rays.o.begin() + 30}, {rays.d.begin(), rays.d.begin() + 30}};
  EXPECT_EQ(differences(ConstSpan<rf_pixel_hit>(all.data(), 10), query(r, ten)), "");
}

// A scattered query longer than a chunk (2^20 rays) is ordered chunk by
// chunk: 3000 random rays repeated past 2^20 give every copy the CPU
// reference's answers for the 3000, the chunk after the first included.
TEST(RayQuery, ScatteredRaysPastOneChunkKeepTheirAnswers) {
  Rng rng(8);
  const Scene scene = testing::random_scene(rng, 3, 10, 200);
  Pipeline cpu(scene, on(Backend::cpu)), cl(scene, on(Backend::opencl));
  const Rays base = random_rays(rng, scene, 3000);
  const std::vector<rf_pixel_hit> want = query(cpu, base);
  const size_t n = (size_t{1} << 20) + 2500;
  Rays many;
  many.o.reserve(3 * n);
  many.d.reserve(3 * n);
  for (size_t i = 0; i < n; ++i) {
    const size_t j = i % base.size();
    many.o.insert(many.o.end(), base.o.begin() + 3 * j, base.o.begin() + 3 * j + 3);
    many.d.insert(many.d.end(), base.d.begin() + 3 * j, base.d.begin() + 3 * j + 3);
  }
  const std::vector<rf_pixel_hit> got = query(cl, many);
  size_t differ = 0, first = n;
  for (size_t i = 0; i < n; ++i)
    if (std::memcmp(&got[i], &want[i % base.size()], sizeof(rf_pixel_hit)) != 0) {
      ++differ;
      first = std::min(first, i);
    }
  EXPECT_EQ(differ, 0u) << "first at ray " << first;
}

// One query whose first chunk of 2^20 rays shares one origin (the tile
// kernel, through the re-braided frame) and whose second is scattered (the
// single-ray kernel, through the frame of whole trees), then the first
// kind again in a second query: each chunk through its own frame.
TEST(RayQuery, ChunksOfBothKindsInOneQueryKeepTheirAnswers) {
  Rng rng(9);
  const Scene scene = testing::random_scene(rng, 3, 10, 200);
  Pipeline cpu(scene, on(Backend::cpu)), cl(scene, on(Backend::opencl));
  const Rays shared = random_rays(rng, scene, 4096, {4096}), scattered = random_rays(rng, scene, 3000);
  const std::vector<rf_pixel_hit> want_shared = query(cpu, shared), want_scattered = query(cpu, scattered);
  const size_t first_chunk = size_t{1} << 20, n = first_chunk + 5000;
  Rays many;
  for (size_t i = 0; i < n; ++i) {
    const Rays& from = i < first_chunk ? shared : scattered;
    const size_t j = i % from.size();
    many.o.insert(many.o.end(), from.o.begin() + 3 * j, from.o.begin() + 3 * j + 3);
    many.d.insert(many.d.end(), from.d.begin() + 3 * j, from.d.begin() + 3 * j + 3);
  }
  for (int pass = 0; pass < 2; ++pass) {
    const std::vector<rf_pixel_hit> got = query(cl, many);
    size_t differ = 0, first = n;
    for (size_t i = 0; i < n; ++i) {
      const rf_pixel_hit& want = i < first_chunk ? want_shared[i % shared.size()] : want_scattered[i % scattered.size()];
      if (std::memcmp(&got[i], &want, sizeof(rf_pixel_hit)) != 0) {
        ++differ;
        first = std::min(first, i);
      }
    }
    EXPECT_EQ(differ, 0u) << "query " << pass << ", first at ray " << first;
  }
}

TEST(RayQuery, InstancesBeyondTheFloatRangeAreReported) {
  // Sizes 2^260 apart cannot share a trace space: the small one is not
  // traced, and the answers say so.
  Scene mixed;
  mixed.meshes.push_back(testing::closed_cube(1));
  mixed.instances.push_back({0, uniform_scale(120), "huge"});
  mixed.instances.push_back({0, uniform_scale(-140), "subnormal"});
  PipelineOptions cpu;
  cpu.backend = Backend::cpu;
  Pipeline r(mixed, cpu);
  const Rays rays{{0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, -1.0f}};
  rf_pixel_hit h;
  const std::vector<std::string> w = r.intersect(rays.o.data(), rays.d.data(), 1, 0.0f, INFINITY, false, {}, &h);
  EXPECT_EQ(h.instance, 0u);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("1 instances not traced"), std::string::npos) << w[0];
  Scene one = mixed;
  one.instances.pop_back();
  Pipeline fine(one, cpu);
  EXPECT_TRUE(fine.intersect(rays.o.data(), rays.d.data(), 1, 0.0f, INFINITY, false, {}, &h).empty());
}

// A scene with nothing to trace (its one instance scaled to nothing)
// answers every ray with a miss through both kernels and the reference,
// scattered rays and rays of one origin alike (a frame without a top level).
TEST(RayQuery, ASceneWithNothingToTraceAnswersMisses) {
  Scene scene;
  scene.meshes.push_back(testing::closed_cube(1));
  scene.instances.push_back({0, glm::scale(Xform(1.0), glm::dvec3(0.0)), "flat"});
  Rng rng(5);
  Rays scattered, shared;
  for (int i = 0; i < 3000; ++i)
    for (int k = 0; k < 3; ++k) {
      scattered.o.push_back(rng.uniformf(-1, 1));
      scattered.d.push_back(rng.uniformf(-1, 1));
      shared.o.push_back(0.5f);
      shared.d.push_back(rng.uniformf(-1, 1));
    }
  for (const Backend backend : {Backend::cpu, Backend::opencl})
    for (const Kernel kernel : {Kernel::single, Kernel::tile}) {
      PipelineOptions o = on(backend);
      o.kernel = kernel;
      Pipeline r(scene, o);
      for (const Rays* rays : {&scattered, &shared})
        for (const rf_pixel_hit& h : query(r, *rays)) {
          ASSERT_EQ(h.instance, RF_INVALID);
          ASSERT_EQ(h.z, INFINITY);
        }
    }
}

TEST(RayQuery, BadRaysNameTheFirst) {
  const Scene scene = square_at_minus_five();
  PipelineOptions opt;
  opt.backend = Backend::cpu;
  Pipeline r(scene, opt);
  auto error = [&](Rays rays, float tmin = 0.0f, float tmax = INFINITY) -> std::string {
    try {
      query(r, rays, tmin, tmax);
    } catch (const rayfold::InputError& e) {
      return e.what();
    }
    return "";
  };
  Rays ok{{0, 0, 0, 0, 0, 0, 0, 0, 0}, {0, 0, -1, 0, 0, -1, 0, 0, -1}};
  EXPECT_EQ(error(ok), "");
  Rays nan_origin = ok;
  nan_origin.o[4] = NAN;
  EXPECT_NE(error(nan_origin).find("ray 1: origin is not finite"), std::string::npos) << error(nan_origin);
  Rays zero = ok;
  zero.d[6] = zero.d[7] = zero.d[8] = 0.0f;
  EXPECT_NE(error(zero).find("ray 2: direction is zero"), std::string::npos) << error(zero);
  Rays inf_dir = ok;
  inf_dir.d[0] = INFINITY;
  EXPECT_NE(error(inf_dir).find("ray 0: direction is not finite"), std::string::npos) << error(inf_dir);
  EXPECT_NE(error(ok, 2.0f, 1.0f).find("0 <= tmin <= tmax"), std::string::npos);
  EXPECT_NE(error(ok, -1.0f).find("0 <= tmin <= tmax"), std::string::npos);
  EXPECT_NE(error(ok, NAN).find("0 <= tmin <= tmax"), std::string::npos);
  EXPECT_EQ(error(Rays{}), "") << "no rays: no answers, no error";
}

// check_query_rays says whether every origin is ray 0's, bit for bit (the
// plan then takes a camera's blocks as its tiles without looking again):
// one bit of one coordinate of one ray anywhere, in any chunk of its pass,
// and a negative zero for a zero, make it false.
TEST(RayQuery, TheCheckSeesWhetherEveryOriginIsTheFirst) {
  const size_t n = 200000;  // past three of the check's chunks of 2^16 rays
  Rays rays;
  for (size_t i = 0; i < n; ++i) {
    rays.o.insert(rays.o.end(), {1.5f, 0.0f, -3.0f});
    rays.d.insert(rays.d.end(), {0.1f, static_cast<float>(i % 7) - 3.0f, -1.0f});
  }
  const size_t width = 400;  // as an image of 500 rows: the plan takes blocks
  bool one = false;
  check_query_rays(rays.o.data(), rays.d.data(), n, 0.0f, INFINITY, &one);
  EXPECT_TRUE(one);
  QueryTiles hinted;
  plan_query_tiles(rays.o.data(), n, width, 128, hinted, one);
  const std::vector<uint32_t> blocks = plan_query_tiles(rays.o.data(), n, width, 128).tiles;
  EXPECT_EQ(hinted.tiles, blocks) << "one origin, told so";
  for (size_t ray : {size_t{1}, size_t{65535}, size_t{65536}, size_t{131073}, n - 1})
    for (int k = 0; k < 3; ++k) {
      Rays moved = rays;
      float& c = moved.o[3 * ray + k];
      c = k == 1 ? -0.0f : std::nextafter(c, INFINITY);
      one = true;
      check_query_rays(moved.o.data(), moved.d.data(), n, 0.0f, INFINITY, &one);
      EXPECT_FALSE(one) << "ray " << ray << ", coordinate " << k << " moved to " << c;
      // The plan told so finds the same: the ray breaks its tile off.
      const QueryTiles told = plan_query_tiles(moved.o.data(), n, width, 128);
      plan_query_tiles(moved.o.data(), n, width, 128, hinted, one);
      EXPECT_EQ(hinted.tiles, told.tiles) << "ray " << ray << ", coordinate " << k;
      EXPECT_GT(told.tiles.size(), blocks.size()) << "the moved ray breaks its block's tile";
    }
  one = false;
  check_query_rays(rays.o.data(), rays.d.data(), 0, 0.0f, INFINITY, &one);
  EXPECT_TRUE(one) << "no rays: every one of them has the first origin";
}

}  // namespace
}  // namespace rayfold::core
