// Exact at every scale: a scene and camera scaled together by 2^k give the
// same instance and primitive ids, barycentrics and normals, bit for bit, and
// depths times 2^k, for k from -100 to 100, whether the scale sits in the
// vertices or in the node transforms; in every fold mode, on the CPU
// reference and in both OpenCL kernels. Also: decimal scales, framing of tiny
// and huge scenes, mixed scales, the input range, and the fuzz regressions.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>

#include <glm/gtc/matrix_transform.hpp>

#include "fold/ray_list.h"
#include "pipeline/pipeline.h"
#include "scene/gltf_loader.h"
#include "test_util.h"
#include "util/errors.h"
#include "util/span.h"

namespace rayfold::core {
namespace {

using testing::Rng;

enum class Placement { vertices, nodes };

// The scene scaled by 2^k, in its vertices (exact in float for these
// magnitudes) or in a scale node above every instance.
Scene scaled(const Scene& scene, int k, Placement where) {
  Scene s = scene;
  if (where == Placement::vertices) {
    for (Mesh& m : s.meshes)
      for (glm::vec3& p : m.positions)
        for (int a = 0; a < 3; ++a) p[a] = std::ldexp(p[a], k);
    // The node translations carry the placement of the scaled meshes.
    for (Instance& inst : s.instances)
      inst.world_from_object[3] = glm::dvec4(glm::dvec3(inst.world_from_object[3]) * std::ldexp(1.0, k), 1.0);
  } else {
    for (Instance& inst : s.instances) inst.world_from_object = uniform_scale(k) * inst.world_from_object;
  }
  return s;
}

CameraSpec scaled(CameraSpec spec, int k) {
  spec.eye *= std::ldexp(1.0, k);
  spec.look_at *= std::ldexp(1.0, k);
  return spec;
}

// "" when `hits` is `base` with every depth times 2^k and everything else
// bit-identical; else the first difference and the count.
std::string compare_scaled(ConstSpan<rf_pixel_hit> base, ConstSpan<rf_pixel_hit> hits, int k,
                           int width) {
  std::vector<rf_pixel_hit> expected(base.begin(), base.end());
  for (rf_pixel_hit& h : expected) h.z = std::ldexp(h.z, k);
  return testing::compare_hits(expected, hits, width);
}

size_t count_hits(ConstSpan<rf_pixel_hit> hits) {
  size_t n = 0;
  for (const rf_pixel_hit& h : hits) n += h.instance != RF_INVALID;
  return n;
}

Scene soup(uint64_t seed) {
  Rng rng(seed);
  return testing::random_scene(rng, 3, 12, 150);
}

// A view of the whole soup from a random side.
CameraSpec soup_camera(uint64_t seed, const Scene& scene) {
  Rng rng(seed);
  const Aabb b = scene.world_bounds();
  CameraSpec spec = frame_bounds(b, 50.0);
  const glm::dvec3 centre = glm::dvec3(b.lo + b.hi) * 0.5;
  const double dist = glm::length(spec.eye - centre);
  const glm::dvec3 dir = glm::normalize(glm::dvec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)));
  spec.eye = centre + dir * dist;
  spec.look_at = centre;
  spec.up = std::fabs(dir.y) > 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  return spec;
}

TEST(Scale, TracedFloatsDoNotDependOnAPowerOfTwoScale) {
  // The mechanism: trees in tree space, rays in trace space. Every float the
  // kernels read is the same at every scale; only the frame's exponent and
  // depth scale move.
  const Scene base = soup(1);
  const CameraSpec spec = soup_camera(2, base);
  const Camera cam0 = make_camera(spec, 32, 24);
  const SceneData d0 = prepare_scene(base, 1);
  const RayList rays = make_ray_list(cam0.params, Fold::xy);
  FrameOptions xy;
  xy.fold = Fold::xy;
  const Frame f0 = build_frame(base, d0, cam0, rays, xy);
  ASSERT_GT(f0.instances.size(), 4u);
  auto same_bytes = [](const auto& a, const auto& b) {
    return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) == 0;
  };
  for (Placement where : {Placement::vertices, Placement::nodes})
    for (int k : {-100, -41, -1, 1, 17, 100}) {
      const Scene s = scaled(base, k, where);
      const Camera cam = make_camera(scaled(spec, k), 32, 24);
      const SceneData d = prepare_scene(s, 1);
      const Frame f = build_frame(s, d, cam, rays, xy);
      const char* w = where == Placement::vertices ? "vertices" : "nodes";
      EXPECT_TRUE(same_bytes(d0.blas.nodes, d.blas.nodes)) << w << " k " << k << ": bottom-level nodes";
      EXPECT_TRUE(same_bytes(d0.blas.tris, d.blas.tris)) << w << " k " << k << ": triangles";
      EXPECT_TRUE(same_bytes(d0.normal_xforms, d.normal_xforms)) << w << " k " << k << ": normal matrices";
      EXPECT_TRUE(same_bytes(f0.instances, f.instances)) << w << " k " << k << ": instances";
      EXPECT_TRUE(same_bytes(f0.tlas_nodes, f.tlas_nodes)) << w << " k " << k << ": top-level nodes";
      EXPECT_EQ(f.views.at(0).trace_exponent, f0.views.at(0).trace_exponent + k) << w;
      EXPECT_EQ(f.views.at(0).depth_scale, std::ldexp(f0.views.at(0).depth_scale, k)) << w;
    }
}

TEST(Scale, EveryPowerOfTwoFromMinus100To100) {
  // The property over the whole range: the CPU reference against the
  // unscaled render, and every fold mode of both OpenCL kernels against the
  // CPU reference (for the second soup at a spread of exponents).
  for (uint64_t seed : {11u, 12u}) {
    const Scene base = soup(seed);
    const CameraSpec spec = soup_camera(seed + 100, base);
    const Camera cam0 = make_camera(spec, 40, 30);
    PipelineOptions cpu;
    cpu.backend = Backend::cpu;
    const HitBuffer ref = Pipeline(base, cpu).render(cam0).hits;
    ASSERT_GT(count_hits(ref), ref.size() / 20) << "seed " << seed << ": the view must see the soup";
    for (Placement where : {Placement::vertices, Placement::nodes})
      for (int k = -100; k <= 100; ++k) {
        const Scene s = scaled(base, k, where);
        const Camera cam = make_camera(scaled(spec, k), 40, 30);
        const char* w = where == Placement::vertices ? "vertices" : "nodes";
        const HitBuffer hits = Pipeline(s, cpu).render(cam).hits;
        EXPECT_EQ(compare_scaled(ref, hits, k, cam.width), "") << "seed " << seed << ", 2^" << k << " in " << w;
        if (seed == 11 || k % 37 == 0 || std::abs(k) == 100) {
          EXPECT_EQ(testing::ThreeWays(s).differences(cam), "") << "seed " << seed << ", 2^" << k << " in " << w;
        }
      }
  }
}

TEST(Scale, SubnormalDepthsKeepEveryOtherChannel) {
  // Found by the fuzz target: at 2^-135 the depths themselves are subnormal
  // floats and have lost bits, which scaling up cannot restore; every other
  // channel stays bit-identical, and nothing is lost.
  const Scene base = soup(61);
  const CameraSpec spec = soup_camera(62, base);
  PipelineOptions cpu;
  cpu.backend = Backend::cpu;
  const Camera cam0 = make_camera(scaled(spec, -135), 40, 30);
  const HitBuffer tiny = Pipeline(scaled(base, -135, Placement::nodes), cpu).render(cam0).hits;
  const HitBuffer ref = Pipeline(base, cpu).render(make_camera(spec, 40, 30)).hits;
  size_t subnormal = 0;
  for (size_t i = 0; i < ref.size(); ++i) {
    rf_pixel_hit a = ref[i], b = tiny[i];
    if (std::fpclassify(b.z) == FP_SUBNORMAL) {
      ++subnormal;
      // Rounded once, to the nearest multiple of 2^-149: half of that away.
      EXPECT_LE(std::fabs(std::ldexp(double(b.z), 135) - a.z), 0x1p-15) << "pixel " << i;
      a.z = b.z = 0.0f;
    } else {
      a.z = std::ldexp(a.z, -135);
    }
    EXPECT_EQ(testing::compare_hits(ConstSpan<rf_pixel_hit>(&a, 1), ConstSpan<rf_pixel_hit>(&b, 1), 1), "") << "pixel " << i;
  }
  EXPECT_EQ(subnormal, count_hits(ref)) << "every depth is subnormal at 2^-135";
  EXPECT_GT(subnormal, 0u);
  // Further down every depth is 0, also found by the fuzz target; the render
  // says so, and the other channels still hold.
  const Camera cam1 = make_camera(scaled(spec, -160), 40, 30);
  const RenderResult zero = Pipeline(scaled(base, -160, Placement::nodes), cpu).render(cam1);
  for (size_t i = 0; i < ref.size(); ++i) {
    rf_pixel_hit a = ref[i], b = zero.hits[i];
    if (a.instance != RF_INVALID) {
      EXPECT_EQ(b.z, 0.0f) << "pixel " << i;
      a.z = b.z;
    }
    EXPECT_EQ(testing::compare_hits(ConstSpan<rf_pixel_hit>(&a, 1), ConstSpan<rf_pixel_hit>(&b, 1), 1), "") << "pixel " << i;
  }
  ASSERT_EQ(zero.warnings.size(), 1u);
  EXPECT_NE(zero.warnings[0].find("below 2^-125"), std::string::npos) << zero.warnings[0];
  EXPECT_TRUE(Pipeline(base, cpu).render(make_camera(spec, 40, 30)).warnings.empty());
}

TEST(Scale, VertexAndNodeScalesGiveTheSameBits) {
  // The same geometry written two ways: a power of two in the vertices or in
  // the node lands in the same tree space, so even the depths agree.
  const Scene base = soup(21);
  const CameraSpec spec = soup_camera(22, base);
  PipelineOptions cpu;
  cpu.backend = Backend::cpu;
  for (int k : {-100, -3, 5, 99}) {
    const Camera cam = make_camera(scaled(spec, k), 40, 30);
    const auto a = Pipeline(scaled(base, k, Placement::vertices), cpu).render(cam).hits;
    const auto b = Pipeline(scaled(base, k, Placement::nodes), cpu).render(cam).hits;
    EXPECT_EQ(testing::compare_hits(a, b, cam.width), "") << "2^" << k;
  }
}

TEST(Scale, DecimalScalesKeepTheirHits) {
  // Scales that are not powers of two round the vertices, so bits may move,
  // but nothing may be lost: before tree space, a soup 1e13 across lost 30%
  // of its hits and one 1e14 or 1e-15 across all of them.
  const Scene base = soup(31);
  const CameraSpec spec = soup_camera(32, base);
  PipelineOptions cpu;
  cpu.backend = Backend::cpu;
  const HitBuffer ref = Pipeline(base, cpu).render(make_camera(spec, 64, 48)).hits;
  const size_t ref_hits = count_hits(ref);
  for (int e = -36; e <= 36; e += 3) {
    const double f = std::pow(10.0, e);
    Scene s = base;
    for (Mesh& m : s.meshes)
      for (glm::vec3& p : m.positions) p = glm::vec3(glm::dvec3(p) * f);
    for (Instance& inst : s.instances)
      inst.world_from_object[3] = glm::dvec4(glm::dvec3(inst.world_from_object[3]) * f, 1.0);
    CameraSpec sc = spec;
    sc.eye *= f;
    sc.look_at *= f;
    const HitBuffer hits = Pipeline(s, cpu).render(make_camera(sc, 64, 48)).hits;
    size_t same = 0;
    for (size_t i = 0; i < hits.size(); ++i) same += hits[i].instance == ref[i].instance;
    EXPECT_NEAR(double(count_hits(hits)), double(ref_hits), 0.01 * ref_hits) << "scale 1e" << e;
    EXPECT_GE(same, hits.size() * 99 / 100) << "scale 1e" << e;
  }
}

TEST(Scale, FramingOfTinyAndHugeScenes) {
  // Auto-framing has no absolute size in it: a scene scaled by 2^k is framed
  // from exactly 2^k times as far, and sees the same hits.
  const Scene base = soup(41);
  const CameraSpec f0 = frame_bounds(base.world_bounds());
  PipelineOptions cpu;
  cpu.backend = Backend::cpu;
  const HitBuffer ref = Pipeline(base, cpu).render(make_camera(f0, 40, 30)).hits;
  for (int k : {-120, -60, -40, 40, 60, 100}) {
    const Scene s = scaled(base, k, Placement::nodes);
    const CameraSpec f = frame_bounds(s.world_bounds());
    EXPECT_EQ(f.eye, f0.eye * std::ldexp(1.0, k)) << "2^" << k;
    EXPECT_EQ(f.look_at, f0.look_at * std::ldexp(1.0, k)) << "2^" << k;
    EXPECT_EQ(compare_scaled(ref, Pipeline(s, cpu).render(make_camera(f, 40, 30)).hits, k, 40), "") << "2^" << k;
  }
  // A scene of one point has nothing to see but still gets a camera.
  Scene point;
  point.meshes.push_back(Mesh{"point", {{1e-30f, 2e-30f, 0.0f}}, {0, 0, 0}});
  point.instances.push_back(Instance{0, Xform(1.0), "point"});
  EXPECT_NO_THROW(make_camera(frame_bounds(point.world_bounds()), 8, 8));
}

TEST(Scale, MixedScalesInOneScene) {
  // A background 1e30 across and an object 1e-20 across in front of the eye:
  // 2^166 apart, more than a float's exponent range holds in one space, yet
  // each instance lives in its own tree space and trace space sits between
  // them. Both are seen, losslessly in every kernel and fold mode.
  Scene s;
  s.meshes.push_back(testing::closed_cube(2));
  s.instances.push_back({0, uniform_scale(100), "background"});                                // [-2^100, 2^100]^3
  Xform tiny = glm::translate(Xform(1.0), glm::dvec3(0.0, 0.0, -3e-20)) * uniform_scale(-67);  // 1.4e-20
  s.instances.push_back({0, tiny, "tiny"});
  CameraSpec spec;
  spec.eye = {0.0, 0.0, 0.0};
  spec.look_at = {0.0, 0.0, -1.0};
  spec.vfov_degrees = 90.0;
  const Camera cam = make_camera(spec, 48, 32);
  testing::ThreeWays r(s);
  const HitBuffer hits = r.reference(cam);
  size_t per_instance[2] = {0, 0};
  for (const rf_pixel_hit& h : hits)
    if (h.instance != RF_INVALID) per_instance[h.instance]++;
  EXPECT_GT(per_instance[0], 0u) << "the background is hidden";
  EXPECT_GT(per_instance[1], 0u) << "the tiny object is lost";
  EXPECT_EQ(per_instance[0] + per_instance[1], hits.size()) << "the eye is inside the background cube";
  EXPECT_EQ(r.differences(cam), "");
  EXPECT_EQ(r.cpu->render(cam).views.at(0).out_of_range, 0u);
}

TEST(Scale, BeyondTheFloatRangeIsRefusedOrReported) {
  // World coordinates past 2^126 are refused naming the node; sizes more
  // than the float range apart in one view are not traced and counted.
  Scene s;
  s.meshes.push_back(testing::closed_cube(1));
  s.instances.push_back({0, uniform_scale(127), "too big"});
  try {
    prepare_scene(s);
    ADD_FAILURE() << "a scene reaching 2^127 was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("too big"), std::string::npos) << e.what();
  }
  CameraSpec far;
  far.eye = {0x1p127, 0.0, 0.0};
  EXPECT_THROW(make_camera(far, 8, 8), InputError);

  Scene mixed;
  mixed.meshes.push_back(testing::closed_cube(1));
  mixed.instances.push_back({0, uniform_scale(120), "huge"});
  mixed.instances.push_back({0, uniform_scale(-140), "subnormal"});
  CameraSpec spec;
  spec.eye = {0.0, 0.0, 0.0};
  PipelineOptions cpu;
  cpu.backend = Backend::cpu;
  const RenderResult r = Pipeline(mixed, cpu).render(make_camera(spec, 16, 16));
  EXPECT_EQ(r.views.at(0).out_of_range, 1u) << "2^260 apart: the small one cannot share a trace space";
  for (const rf_pixel_hit& h : r.hits) EXPECT_EQ(h.instance, 0u);
  ASSERT_EQ(r.warnings.size(), 1u);
  EXPECT_NE(r.warnings[0].find("1 instances not rendered"), std::string::npos) << r.warnings[0];
}

TEST(Scale, TrianglesTooSmallForTheirMeshAreReported) {
  // One mesh from 0 to 1e27 with a unit triangle near its origin: in tree
  // space the small one is 2^-90 of the mesh, below what the watertight
  // test's products resolve. The render stays lossless across kernels and
  // folds, and says what it may miss.
  Scene s;
  Mesh m;
  m.name = "mixed";
  m.positions = {{0, 0, -5}, {1e27f, 0, -5}, {0, 1e27f, -5}, {-1, -1, -3}, {1, -1, -3}, {0, 1, -3}};
  m.indices = {0, 1, 2, 3, 4, 5};
  s.meshes.push_back(m);
  s.instances.push_back({0, Xform(1.0), "mixed"});
  CameraSpec spec;
  const Camera cam = make_camera(spec, 24, 16);
  testing::ThreeWays r(s);
  EXPECT_EQ(r.differences(cam), "");
  const RenderResult result = r.cpu->render(cam);
  ASSERT_EQ(result.warnings.size(), 1u);
  EXPECT_NE(result.warnings[0].find("1 triangles are smaller than 2^-60"), std::string::npos) << result.warnings[0];
  s.meshes[0].positions[1].x = 1e12f;  // 2^-40 apart: resolved, no warning
  s.meshes[0].positions[2].y = 1e12f;
  PipelineOptions cpu;
  cpu.backend = Backend::cpu;
  EXPECT_TRUE(Pipeline(s, cpu).render(cam).warnings.empty());
}

TEST(Scale, ViewsFinerThanFloatPositionsAreReported) {
  // Seen from 1e8 times its size through a view that keeps it in frame, an
  // object is lost by every float tracer (rayfold-limits); the render says so.
  const Scene scene = soup(51);
  PipelineOptions cpu;
  cpu.backend = Backend::cpu;
  Pipeline renderer(scene, cpu);
  for (double d : {10.0, 1e3, 1e5, 1e8}) {
    const double vfov = 2.0 * std::asin(1.0 / d) * 180.0 / M_PI;
    const Camera cam = make_camera(frame_bounds(scene.world_bounds(), vfov), 64, 48);
    const RenderResult r = renderer.render(cam);
    EXPECT_EQ(r.warnings.size(), pixel_angle(cam) < kFinestPixelAngle ? 1u : 0u) << "distance " << d;
    EXPECT_EQ(pixel_angle(cam) < kFinestPixelAngle, d > 1e4) << "distance " << d;
  }
}

TEST(Scale, FuzzRegressionsRenderLosslessly) {
  // ../shared/regressions: files found by make fuzz with coordinates from
  // 1e21 to 1e37 that once rendered differently folded and unfolded.
  namespace fs = std::filesystem;
  const fs::path dir = fs::path(RAYFOLD_SOURCE_DIR) / ".." / "shared" / "regressions";
  if (!fs::is_directory(dir)) GTEST_SKIP() << dir << " not found; fuzz regressions not tested";
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().extension() != ".glb" && entry.path().extension() != ".gltf") continue;
    ++files;
    Scene scene;
    try {
      scene = load_gltf(entry.path().string());
    } catch (const InputError& e) {
      // Refused is allowed, but only for the documented range.
      EXPECT_NE(std::string(e.what()).find("(2^126)"), std::string::npos) << e.what();
      continue;
    }
    const CameraSpec spec = scene.camera ? *scene.camera : frame_bounds(scene.world_bounds());
    testing::ThreeWays r(scene);
    for (auto [w, h] : {std::pair{9, 7}, {64, 48}, {320, 180}}) {
      const Camera cam = make_camera(spec, w, h);
      EXPECT_EQ(r.differences(cam), "") << entry.path().filename() << " at " << w << "x" << h;
    }
  }
  EXPECT_GT(files, 0);
}

}  // namespace
}  // namespace rayfold::core
