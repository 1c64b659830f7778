// The tile kernel equals the single-ray kernel and the CPU reference, bit for
// bit on every field of every pixel, in every fold mode: the default scene,
// random cameras over generated scenes and mirrored soups, odd and tiny
// sizes, shifted windows, animated frames and the real scenes.
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <string>

#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <memory>
#include <utility>

#include <glm/gtc/matrix_transform.hpp>

#include "fixtures/scene_gen.h"
#include "bvh/bvh_build.h"
#include "pipeline/pipeline.h"
#include "rf_trace.h"
#include "scene/gltf_loader.h"
#include "test_util.h"

namespace rayfold::core {
namespace {

using testing::ThreeWays;

TEST(TileKernel, IntervalBoundRejectsOnlyWhatEveryLaneRejects) {
  // rf_interval_box over a packet sharing one origin: when it rejects a box,
  // every lane's scalar slab test rejects it too, and its entry bound is at
  // most every passing lane's entry distance. Packets of primary rays through
  // random transforms, with zero components and flat boxes mixed in.
  testing::Rng rng(99);
  size_t rejected = 0, checked = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    float m[12];
    for (float& f : m) f = rng.uniformf(-2, 2);
    const int rays = 1 + rng.below(64);
    const float s = rng.uniformf(1e-4f, 0.05f);
    const int x0 = rng.below(60) - 30, y0 = rng.below(60) - 30;
    std::vector<rf_ray> lanes(rays);
    float lo[3] = {RF_FAR, RF_FAR, RF_FAR}, hi[3] = {-RF_FAR, -RF_FAR, -RF_FAR};
    for (int l = 0; l < rays; ++l) {
      const float dx = (trial % 5 == 0 && l % 3 == 0) ? 0.0f : s * static_cast<float>(2 * (x0 + l % 8) + 1);
      const float dy = s * static_cast<float>(2 * (y0 + l / 8) + 1);
      rf_ray_to_object(&lanes[l], m, dx, dy, -1.0f);
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], lanes[l].invd[k]);
        hi[k] = std::max(hi[k], lanes[l].invd[k]);
      }
    }
    rf_node box{};
    for (int k = 0; k < 3; ++k) {
      const float a = rng.uniformf(-4, 4), b = rng.uniformf(-4, 4);
      box.bmin[k] = std::min(a, b);
      box.bmax[k] = (trial % 7 == 0 && k == 2) ? box.bmin[k] : std::max(a, b);
    }
    const float tmax = trial % 3 == 0 ? RF_FAR : rng.uniformf(0, 10);
    const float o[3] = {lanes[0].o[0], lanes[0].o[1], lanes[0].o[2]};
    const float c0[3] = {box.bmin[0] - o[0], box.bmin[1] - o[1], box.bmin[2] - o[2]};
    const float c1[3] = {box.bmax[0] - o[0], box.bmax[1] - o[1], box.bmax[2] - o[2]};
    const float bound = rf_interval_box(c0, c1, lo, hi, tmax);
    rejected += bound == RF_FAR;
    for (int l = 0; l < rays; ++l) {
      const float lane = rf_intersect_box(&box, &lanes[l], tmax);
      if (lane == RF_FAR) continue;
      ++checked;
      ASSERT_NE(bound, RF_FAR) << "trial " << trial << " lane " << l << " enters at " << lane;
      ASSERT_LE(bound, lane) << "trial " << trial << " lane " << l;
    }
    if (rays == 1) {
      // One ray: the packet test is the scalar test.
      EXPECT_EQ(bound, rf_intersect_box(&box, &lanes[0], tmax)) << "trial " << trial;
    }
  }
  EXPECT_GT(rejected, 400u);  // both outcomes are exercised
  EXPECT_GT(checked, 4000u);
}

TEST(TileKernel, ChosenByDefaultOnCpuDevices) {
  const Scene scene = load_gltf(std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb");
  const Pipeline r(scene, PipelineOptions{});
  const bool cpu_device = testing::test_device().info().is_cpu;
  EXPECT_EQ(r.kernel_label(), cpu_device ? "tile" : "single");
  PipelineOptions o;
  o.kernel = Kernel::single;
  EXPECT_EQ(Pipeline(scene, o).kernel_label(), "single");
}

TEST(TileKernel, MeasuredChoiceKeepsTheFasterKernelAndTheSameBits) {
  // What auto does on GPUs: the first frame is traced by both kernels, the
  // faster one stays. On PoCL that is the tile kernel by a wide margin.
  const Scene scene = load_gltf(std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb");
  PipelineOptions o;
  o.kernel = Kernel::measure;
  Pipeline measured(scene, o);
  EXPECT_EQ(measured.kernel_reason(), "to be measured");
  PipelineOptions cpu;
  cpu.backend = Backend::cpu;
  Pipeline reference(scene, cpu);
  const Camera cam = make_camera(*scene.camera, 320, 180);
  FrameOptions xy;
  xy.fold = Fold::xy;
  EXPECT_EQ(testing::compare_hits(reference.render(cam).hits, measured.render(cam, 2, xy).hits, cam.width), "");
  EXPECT_NE(measured.kernel_reason().find("measured on the first frame: tile"), std::string::npos)
      << measured.kernel_reason();
  if (testing::test_device().info().is_cpu) {
    EXPECT_EQ(measured.kernel_label(), "tile") << measured.kernel_reason();
  }
}

TEST(TileKernel, DefaultSceneFullSizeEveryFold) {
  const Scene scene = load_gltf(std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb");
  ThreeWays r(scene);
  const Camera cam = make_camera(*scene.camera, 1280, 720);
  EXPECT_EQ(r.differences(cam), "");
}

TEST(TileKernel, OddAndTinySizesAndShifts) {
  const Scene scene = load_gltf(std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb");
  ThreeWays r(scene);
  for (auto [w, h] : std::vector<std::pair<int, int>>{{1, 1}, {3, 3}, {17, 9}, {16, 16}, {33, 17}, {1279, 719}}) {
    EXPECT_EQ(r.differences(make_camera(*scene.camera, w, h)), "") << w << "x" << h;
  }
  for (auto [sx, sy] : std::vector<std::pair<double, double>>{{0.3, 0.0}, {0.0, -0.45}, {-0.7, 0.2}, {1.2, 1.1}}) {
    EXPECT_EQ(r.differences(make_camera(*scene.camera, 97, 61, sx, sy)), "") << "shift " << sx << "," << sy;
  }
}

// FrameOptions::normals off: every tracer writes zero normals (it skips the
// normal's arithmetic) and every other field of the render with normals.
TEST(TileKernel, NormalsOffWriteZeroNormalsAndTheSameRest) {
  const Scene scene = load_gltf(std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb");
  ThreeWays r(scene);
  const Camera cam = make_camera(*scene.camera, 97, 41);
  for (Fold fold : {Fold::none, Fold::xy}) {
    FrameOptions with;
    with.fold = fold;
    FrameOptions without = with;
    without.normals = false;
    for (Pipeline* renderer : {r.cpu.get(), r.single.get(), r.tile.get()}) {
      const HitBuffer a = renderer->render(cam, 1, with).hits;
      const HitBuffer b = renderer->render(cam, 1, without).hits;
      ASSERT_EQ(a.size(), b.size());
      size_t hits = 0;
      for (size_t i = 0; i < a.size(); ++i) {
        ASSERT_TRUE(b[i].nx == 0.0f && b[i].ny == 0.0f && b[i].nz == 0.0f) << renderer->kernel_label() << " " << i;
        rf_pixel_hit expect = a[i];
        expect.nx = expect.ny = expect.nz = 0.0f;
        ASSERT_EQ(std::memcmp(&expect, &b[i], sizeof expect), 0) << renderer->kernel_label() << " pixel " << i;
        hits += a[i].instance != RF_INVALID;
      }
      EXPECT_GT(hits, a.size() / 4) << renderer->kernel_label();
    }
  }
}

// FrameOptions::planar_depth: every tracer writes the same bits, each z the
// ray distance times the cosine of the pixel's ray to the camera axis, and
// the rest of the pixel as the distance render's.
TEST(TileKernel, PlanarDepthIsTheDistanceAlongTheCameraAxis) {
  const Scene scene = load_gltf(std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb");
  ThreeWays r(scene);
  const Camera cam = make_camera(*scene.camera, 97, 41);
  for (Fold fold : {Fold::none, Fold::xy}) {
    FrameOptions distance;
    distance.fold = fold;
    FrameOptions planar = distance;
    planar.planar_depth = true;
    const HitBuffer ref = r.cpu->render(cam, 1, planar).hits;
    for (Pipeline* renderer : {r.cpu.get(), r.single.get(), r.tile.get()}) {
      const HitBuffer a = renderer->render(cam, 1, distance).hits;
      const HitBuffer b = renderer->render(cam, 1, planar).hits;
      ASSERT_EQ(std::memcmp(b.data(), ref.data(), b.size() * sizeof(rf_pixel_hit)), 0) << renderer->kernel_label();
      size_t hits = 0;
      for (int y = 0; y < cam.height; ++y)
        for (int x = 0; x < cam.width; ++x) {
          const size_t i = static_cast<size_t>(y) * cam.width + x;
          rf_pixel_hit rest = b[i];
          rest.z = a[i].z;
          ASSERT_EQ(std::memcmp(&rest, &a[i], sizeof rest), 0) << renderer->kernel_label() << " pixel " << i;
          if (a[i].instance == RF_INVALID) {
            EXPECT_EQ(b[i].z, RF_INF);
            continue;
          }
          const glm::dvec3 d = exact_direction(cam, x, y);
          const double cosine = -d.z / glm::length(d);
          EXPECT_NEAR(b[i].z, a[i].z * cosine, 1e-6 * a[i].z) << renderer->kernel_label() << " pixel " << i;
          ++hits;
        }
      EXPECT_GT(hits, b.size() / 4);
    }
  }
}

TEST(TileKernel, AnimatedFrames) {
  const Scene scene = load_gltf(std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb");
  ThreeWays r(scene);
  const Camera cam = make_camera(*scene.camera, 160, 90);
  for (int frame : {0, 5, 23}) EXPECT_EQ(r.differences(cam, frame), "") << "frame " << frame;
}

TEST(TileKernel, RandomCamerasOverGeneratedScenes) {
  // 102 cameras: roll, axis-aligned views, the eye inside objects, shifted
  // windows, sizes from 1x1; over generated atriums with non-uniformly
  // scaled and mirrored instances.
  testing::Rng rng(2718);
  int cameras = 0;
  for (int s = 0; s < 3; ++s) {
    Scene scene = testing::generated_atrium(700 + s, 25 + 60 * s, 15000);
    // Mirrored instances too (every fifth, in object space: winding flips).
    for (size_t i = 0; i < scene.instances.size(); i += 5)
      scene.instances[i].world_from_object =
          scene.instances[i].world_from_object * glm::scale(Xform(1.0), glm::dvec3(-1, 1, 1));
    ThreeWays r(scene);
    for (int v = 0; v < 34; ++v, ++cameras) {
      CameraSpec spec = testing::random_camera(rng, scene.world_bounds());
      if (v % 5 == 0) testing::move_eye_inside_an_instance(rng, scene, spec);
      const int w = 1 + rng.below(120), h = 1 + rng.below(80);
      const double sx = v % 3 == 0 ? rng.uniform(-0.8, 0.8) : 0.0, sy = v % 4 == 0 ? rng.uniform(-0.8, 0.8) : 0.0;
      EXPECT_EQ(r.differences(make_camera(spec, w, h, sx, sy)), "")
          << "scene " << s << " camera " << v << " " << w << "x" << h;
    }
  }
  EXPECT_GE(cameras, 100);
}

TEST(TileKernel, RandomMirroredSoups) {
  // Mirrored and non-uniformly scaled instances, zero-area triangles, wide
  // and narrow fields of view: lanes of one tile with different axis
  // permutations in object space.
  testing::Rng rng(4242);
  int cameras = 0;
  for (int s = 0; s < 6; ++s) {
    const Scene scene = testing::random_scene(rng, 3, 14, 300);
    ThreeWays r(scene);
    for (int v = 0; v < 6; ++v, ++cameras) {
      CameraSpec spec = testing::random_camera(rng, scene.world_bounds());
      spec.vfov_degrees = v % 3 == 0 ? 150.0 : spec.vfov_degrees;
      EXPECT_EQ(r.differences(make_camera(spec, 48 + v * 7, 40 - v * 3)), "") << "soup " << s << " view " << v;
    }
  }
  EXPECT_GE(cameras, 30);
}

TEST(TileKernel, LanesTakeOnlyHitsTheirOwnBoxTestsReach) {
  // Regression: the eye inside a closed lattice cube. The centre row's rays
  // have dy = 0 and run along the box faces y = 0 of the cube's leaves; the
  // scalar slab test rejects the box below that plane, the watertight test
  // would still hit its triangles on the shared edge at the same t, and the
  // tie rule would pick the other triangle. A lane that tested triangles of
  // leaves its group entered for other lanes took them (1 to 34 pixels of
  // 65x65 differed).
  Scene scene;
  scene.meshes.push_back(testing::closed_cube(8));
  scene.instances.push_back({0, Xform(1.0), "cube"});
  ThreeWays r(scene);
  for (const glm::dvec3 look : {glm::dvec3(0, 0, -1), glm::dvec3(1, 0, 0), glm::dvec3(1, 0, 1)}) {
    CameraSpec spec;
    spec.eye = glm::dvec3(0.0);
    spec.look_at = look;
    spec.vfov_degrees = 100.0;
    for (int size : {65, 64}) EXPECT_EQ(r.differences(make_camera(spec, size, size)), "") << size;
  }
}

TEST(TileKernel, LaneGroupsOnOneTriangleOfTwoInstancesTakeEachItsOwnNormal) {
  // A lane group whose lanes all hit one triangle of one instance takes
  // the normal made for the last such group when the triangle and the
  // instance are the same. Here one triangle's mesh is instanced twice,
  // tilted differently, one in front of the other: the lane groups of a
  // tile on either side of the front one's edge hit triangle 0 of two
  // instances with two normals. A normal kept by triangle alone gives one
  // instance's lanes the other's.
  Scene scene;
  scene.meshes.push_back(testing::unit_triangle());
  const Xform back = glm::translate(Xform(1.0), glm::dvec3(0.0, 0.0, -10.0)) *
                     glm::rotate(Xform(1.0), glm::radians(20.0), glm::dvec3(0.0, 1.0, 0.0)) *
                     glm::scale(Xform(1.0), glm::dvec3(12.0));
  const Xform front = glm::translate(Xform(1.0), glm::dvec3(0.3, -0.2, -5.0)) *
                      glm::rotate(Xform(1.0), glm::radians(-35.0), glm::dvec3(1.0, 0.0, 0.0)) *
                      glm::scale(Xform(1.0), glm::dvec3(1.5));
  scene.instances.push_back({0, back, "back"});
  scene.instances.push_back({0, front, "front"});
  ThreeWays r(scene);
  CameraSpec spec;
  spec.vfov_degrees = 50.0;
  const Camera cam = make_camera(spec, 96, 80);
  // The premise: both instances are seen, each over whole lane groups.
  const HitBuffer ref = r.reference(cam);
  size_t seen[2] = {0, 0};
  for (const rf_pixel_hit& h : ref)
    if (h.instance < 2) ++seen[h.instance];
  EXPECT_GT(seen[0], 1000u);
  EXPECT_GT(seen[1], 1000u);
  EXPECT_EQ(r.differences(cam), "");
}

// A unit sphere of kU x kV quads as two triangles each, every triangle
// written `copies` times (the same vertices, consecutive primitive ids).
Scene sphere_scene(int ku, int kv, int copies) {
  Mesh sphere;
  for (int v = 0; v <= kv; ++v)
    for (int u = 0; u <= ku; ++u) {
      const double th = M_PI * v / kv, ph = 2.0 * M_PI * u / ku;
      sphere.positions.push_back(
          glm::vec3(glm::dvec3(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph))));
    }
  for (int v = 0; v < kv; ++v)
    for (int u = 0; u < ku; ++u) {
      const uint32_t a = static_cast<uint32_t>(v * (ku + 1) + u), b = a + 1, c = a + ku + 1, d = c + 1;
      for (const std::array<uint32_t, 3>& t : {std::array<uint32_t, 3>{a, c, b}, std::array<uint32_t, 3>{b, c, d}})
        for (int copy = 0; copy < copies; ++copy) sphere.indices.insert(sphere.indices.end(), t.begin(), t.end());
    }
  Scene scene;
  scene.meshes.push_back(sphere);
  scene.instances.push_back({0, Xform(1.0), "sphere"});
  return scene;
}

TEST(TileKernel, DenseScenesTraceWithEightLanesUnlessAsked) {
  DeviceInfo avx512, avx2;
  avx512.native_float_width = 16;
  avx2.native_float_width = 8;
  const char* env = std::getenv("RAYFOLD_TILE_LANES");
  const std::string saved = env ? env : "";
  unsetenv("RAYFOLD_TILE_LANES");
  EXPECT_EQ(tile_lanes(avx512, 0, false), 16u);
  EXPECT_EQ(tile_lanes(avx512, 0, true), 8u);
  EXPECT_EQ(tile_lanes(avx2, 0, false), 8u);
  EXPECT_EQ(tile_lanes(avx2, 0, true), 8u);
  EXPECT_EQ(tile_lanes(avx512, 16, true), 16u);  // asked for: kept
  setenv("RAYFOLD_TILE_LANES", "16", 1);
  EXPECT_EQ(tile_lanes(avx512, 0, true), 16u);  // the environment's word beats the default
  if (env)
    setenv("RAYFOLD_TILE_LANES", saved.c_str(), 1);
  else
    unsetenv("RAYFOLD_TILE_LANES");

  // A dense mesh (one of dense_triangles) and a sparse one: the renderer's
  // width follows, and a dense scene forced to 16 lanes gives the bits of
  // its default 8.
  const Scene dense = sphere_scene(256, 256, 1);
  ASSERT_GE(dense.meshes[0].triangle_count(), BuildOptions{}.dense_triangles);
  const Scene sparse = sphere_scene(64, 32, 1);
  const DeviceInfo& info = testing::test_device().info();
  PipelineOptions o;
  o.kernel = Kernel::tile;
  Pipeline dense_default(dense, o);
  EXPECT_EQ(dense_default.tile_lanes(), tile_lanes(info, 0, true));
  EXPECT_EQ(Pipeline(sparse, o).tile_lanes(), tile_lanes(info, 0, false));
  o.tuning.tile_lanes = 16;
  Pipeline dense_16(dense, o);
  EXPECT_EQ(dense_16.tile_lanes(), 16u);
  CameraSpec spec;
  spec.eye = glm::dvec3(2, 1.5, 1.2);
  spec.look_at = glm::dvec3(0.0);
  spec.vfov_degrees = 45.0;
  const Camera cam = make_camera(spec, 96, 64);
  for (Fold fold : {Fold::none, Fold::xy}) {
    FrameOptions f;
    f.fold = fold;
    const HitBuffer a = dense_default.render(cam, 1, f).hits, b = dense_16.render(cam, 1, f).hits;
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(std::memcmp(a.data(), b.data(), a.size() * sizeof(rf_pixel_hit)), 0);
  }
}

TEST(TileKernel, DuplicatedTrianglesOfADenseMeshTakeTheLowerPrimitive) {
  // A sphere of about 150k triangles, each written twice (the same
  // vertices, two primitive ids), so that it is built as a dense mesh
  // (fuller leaves) with both copies in one leaf, seen whole in small
  // images. Every hit meets both copies at the same t, so the tie rule (the
  // lower primitive) decides every pixel: a lane that takes the higher copy
  // differs from the CPU reference. No other test ties every pixel.
  const Scene scene = sphere_scene(240, 160, 2);
  ASSERT_GE(scene.meshes[0].triangle_count(), BuildOptions{}.dense_triangles);
  ThreeWays r(scene);
  // A dense scene's tile kernel defaults to 8 lanes: the 16-lane build too.
  PipelineOptions wide;
  wide.kernel = Kernel::tile;
  wide.tuning.tile_lanes = 16;
  Pipeline tile16(scene, wide);
  for (const glm::dvec3 eye : {glm::dvec3(0, 0, 3), glm::dvec3(2, 1.5, 1.2)}) {
    CameraSpec spec;
    spec.eye = eye;
    spec.look_at = glm::dvec3(0.0);
    spec.vfov_degrees = 45.0;
    for (const auto& [w, h] : {std::pair{48, 40}, std::pair{17, 9}}) {
      const Camera cam = make_camera(spec, w, h);
      // The premise: every hit is the lower copy, an even primitive.
      size_t hits = 0, odd = 0;
      for (const rf_pixel_hit& p : r.reference(cam))
        if (p.instance != RF_INVALID) {
          ++hits;
          odd += p.primitive % 2u;
        }
      EXPECT_GT(hits, static_cast<size_t>(w * h) / 4);
      EXPECT_EQ(odd, 0u);
      EXPECT_EQ(r.differences(cam), "") << w << "x" << h;
      const HitBuffer ref = r.reference(cam);
      for (Fold fold : {Fold::none, Fold::y, Fold::x, Fold::xy}) {
        FrameOptions f;
        f.fold = fold;
        const HitBuffer b = tile16.render(cam, 1, f).hits;
        ASSERT_EQ(b.size(), ref.size());
        EXPECT_EQ(std::memcmp(b.data(), ref.data(), b.size() * sizeof(rf_pixel_hit)), 0)
            << "16 lanes, fold " << static_cast<int>(fold) << ", " << w << "x" << h;
      }
    }
  }
}

TEST(TileKernel, SharedScenes) {
  if (testing::shared_scenes_dir().empty())
    GTEST_SKIP() << "../shared/scenes not found (set RAYFOLD_SCENES_DIR); real scenes not tested";
  const int rendered = testing::for_each_shared_scene([](const testing::SharedView& v, const Scene& scene) {
    ThreeWays r(scene);
    EXPECT_EQ(r.differences(make_camera(v.camera(), 203, 117)), "") << v.file;
  });
  EXPECT_GT(rendered, 0);
}

}  // namespace
}  // namespace rayfold::core
