// The exact depth (kernels/rf_depth.h, FrameOptions::exact_depth): every
// tracer and fold gives the same bits as the CPU reference and as brute force
// written in object space; each depth is within one rounding of the double
// reference's, where the float depth of the same views is not; planar and
// orthographic depths too.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "reference/double_reference.h"
#include "pipeline/pipeline.h"
#include "scene/gltf_loader.h"
#include "test_util.h"
#include "util/span.h"

namespace rayfold::core {
namespace {

using testing::Rng;

FrameOptions exact(Fold fold = Fold::none) {
  FrameOptions o;
  o.fold = fold;
  o.exact_depth = true;
  return o;
}

// The largest relative depth error against the double reference over the
// pixels that hit its triangle, and how many there were.
std::pair<double, size_t> worst_depth(const std::vector<ReferenceHit>& ref, ConstSpan<rf_pixel_hit> hits) {
  double worst = 0.0;
  size_t n = 0;
  for (size_t i = 0; i < ref.size(); ++i) {
    if (ref[i].instance == RF_INVALID || ref[i].instance != hits[i].instance || ref[i].primitive != hits[i].primitive)
      continue;
    worst = std::max(worst, std::fabs(hits[i].z - ref[i].distance) / ref[i].distance);
    ++n;
  }
  return {worst, n};
}

TEST(ExactDepth, KernelsEqualTheCpuReferenceInEveryFold) {
  // Mirrored, non-uniformly scaled instances; off-centre principal points;
  // eyes inside objects; orthographic views; planar depth.
  Rng rng(4242);
  int views = 0;
  for (int s = 0; s < 3; ++s) {
    const Scene scene = testing::generated_atrium(700 + s, 20 + 40 * s, 12000);
    testing::ThreeWays r(scene);
    for (int v = 0; v < 8; ++v, ++views) {
      CameraSpec spec = v % 4 == 3 ? testing::random_ortho_camera(rng, scene.world_bounds())
                                   : testing::random_camera(rng, scene.world_bounds());
      if (v % 4 == 1) testing::move_eye_inside_an_instance(rng, scene, spec);
      const double sx = v % 3 == 0 ? rng.uniform(-0.8, 0.8) : 0.0;
      const double sy = v % 4 == 2 ? rng.uniform(-0.8, 0.8) : 0.0;
      const Camera cam = make_camera(spec, 24 + rng.below(60), 16 + rng.below(50), sx, sy);
      FrameOptions o = exact();
      o.planar_depth = v % 2 == 1;
      EXPECT_EQ(r.differences(cam, -1, o), "") << "scene " << s << " view " << v;
    }
  }
  Rng soups(77);
  for (int s = 0; s < 2; ++s) {
    const Scene scene = testing::random_scene(soups, 2, 12, 150);
    testing::ThreeWays r(scene);
    for (int v = 0; v < 3; ++v, ++views) {
      const Camera cam = make_camera(testing::random_camera(soups, scene.world_bounds()), 33 + v, 24 + v);
      EXPECT_EQ(r.differences(cam, -1, exact()), "") << "soup " << s << " view " << v;
    }
  }
  EXPECT_GE(views, 30);
}

TEST(ExactDepth, OnePrincipalPointOffsetFoldsTheOtherAxisWithItsOwnRayLengths) {
  // The tile kernel makes a ray's exact length once for its mirror pixels,
  // which holds along an axis that folds; a principal point off the
  // half-pixel grid along the other axis gives every pixel an offset there
  // that a shared length must keep (negated along it, the length differs).
  Rng rng(3131);
  const Scene scene = testing::generated_atrium(717, 30, 8000);
  testing::ThreeWays r(scene);
  int folded = 0;
  for (int v = 0; v < 4; ++v) {
    const Xform world_from_camera =
        make_camera(testing::random_camera(rng, scene.world_bounds()), 8, 8).world_from_camera;
    const int w = 45 + v, h = 31 + v;
    const double on = 0.5 * w + 1.0, off = 0.5 * h + 0.3;  // on the grid: a whole pixel off centre
    const Intrinsics k =
        v % 2 == 0 ? Intrinsics{40.0, 37.0, on, off} : Intrinsics{40.0, 37.0, 0.5 * w + 0.3, 0.5 * h - 1.0};
    const Camera cam = make_camera(world_from_camera, k, w, h);
    ASSERT_NE(can_fold_columns(cam), can_fold_rows(cam)) << "view " << v;
    FrameOptions o = exact();
    o.planar_depth = v == 3;
    EXPECT_EQ(r.differences(cam, -1, o), "") << "view " << v;
    folded += r.tile->render(cam, 1, exact(Fold::xy)).fold != Fold::none;
  }
  EXPECT_EQ(folded, 4);
}

TEST(ExactDepth, LanesOnOneTriangleOfTwoInstances) {
  // Two instances of a one-triangle mesh cover the two halves of a square:
  // the tile kernel's lanes along the diagonal hit the same triangle index
  // in different instances, and each lane takes its own instance's transform.
  // (Found on a random view of the atrium, where one transform served them
  // all and 72 pixels were off by 7%.)
  Scene scene;
  Mesh tri;
  tri.positions = {{0, 0, 0}, {4, 0, 0}, {0, 4, 0}};
  tri.indices = {0, 1, 2};
  scene.meshes.push_back(tri);
  scene.instances.push_back({0, Xform(1.0), "lower left"});
  // The other half: the same triangle turned half a turn about (2, 2) and
  // lowered (a plane of its own, seen past the first one's edge).
  Xform turned(1.0);
  turned[0][0] = -1.0;
  turned[1][1] = -1.0;
  turned[3] = glm::dvec4(4.0, 4.0, -0.5, 1.0);
  scene.instances.push_back({0, turned, "upper right"});
  testing::ThreeWays r(scene);
  CameraSpec spec;
  spec.eye = {-1.5, 0.5, 3.0};
  spec.look_at = {2.0, 2.0, 0.0};
  spec.vfov_degrees = 70.0;
  for (auto [w, h] : std::vector<std::pair<int, int>>{{64, 48}, {97, 61}}) {
    const Camera cam = make_camera(spec, w, h);
    EXPECT_EQ(r.differences(cam, -1, exact()), "") << w << "x" << h;
    const std::vector<ReferenceHit> ref = trace_double_reference(scene, r.cpu->scene_data(), cam);
    const auto [worst, n] = worst_depth(ref, r.tile->render(cam, 1, exact()).hits);
    EXPECT_LE(worst, 0x1p-23) << w << "x" << h;
    EXPECT_GT(n, static_cast<size_t>(w * h / 8));
  }
}

TEST(ExactDepth, AnimatedFramesKeepTheirBits) {
  // Animation rewrites the moving instances' transforms, and so their
  // table entries, every frame.
  const Scene scene = load_gltf(std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb");
  testing::ThreeWays r(scene);
  const Camera cam = make_camera(*scene.camera, 96, 54);
  for (int frame : {0, 7, 23}) EXPECT_EQ(r.differences(cam, frame, exact()), "") << "frame " << frame;
}

TEST(ExactDepth, EqualsBruteForceInObjectSpace) {
  // Brute force takes the same double-float steps in object and camera
  // space, which differ from tree and trace space by powers of two.
  Rng rng(91);
  for (int s = 0; s < 3; ++s) {
    const Scene scene = testing::random_scene(rng, 2, 10, 120);
    PipelineOptions cpu;
    cpu.backend = Backend::cpu;
    Pipeline r(scene, cpu);
    for (int v = 0; v < 4; ++v) {
      const Camera cam =
          make_camera(testing::random_camera(rng, scene.world_bounds()), 31 + v, 22 + v, v % 2 ? 0.3 : 0.0, 0.0);
      const std::vector<rf_pixel_hit> expected = testing::brute_force(scene, r.scene_data(), cam, true);
      for (Fold f : {Fold::none, Fold::xy})
        EXPECT_EQ(testing::compare_hits(expected, r.render(cam, 1, exact(f)).hits, cam.width), "")
            << "scene " << s << " view " << v << " fold " << fold_name(f);
    }
  }
}

TEST(ExactDepth, WithinOneRoundingOfTheDoubleReference) {
  // Eyes inside generated interiors, looking anywhere: grazing floors and
  // walls, hits near the eye far from their tree's origin. The exact depth is
  // within 2^-23 (one rounding, with room for the reference's own) on every
  // pixel; the float depth of the same views is not, so the views do reach
  // the tail.
  Rng rng(515);
  double float_worst = 0.0;
  size_t pixels = 0;
  for (int s = 0; s < 2; ++s) {
    const Scene scene = testing::generated_atrium(900 + s, 60, 20000);
    PipelineOptions o;
    o.kernel = Kernel::tile;
    Pipeline r(scene, o);
    for (int v = 0; v < 4; ++v) {
      CameraSpec spec = testing::random_camera(rng, scene.world_bounds());
      if (v % 2 == 0) testing::move_eye_inside_an_instance(rng, scene, spec);
      const Camera cam = make_camera(spec, 160, 120);
      const std::vector<ReferenceHit> ref = trace_double_reference(scene, r.scene_data(), cam);
      const auto [worst, n] = worst_depth(ref, r.render(cam, 1, exact()).hits);
      EXPECT_LE(worst, 0x1p-23) << "scene " << s << " view " << v;
      float_worst = std::max(float_worst, worst_depth(ref, r.render(cam).hits).first);
      pixels += n;
    }
  }
  EXPECT_GT(pixels, 20000u);
  EXPECT_GT(float_worst, 0x1p-21) << "the views never left the float depth's first bits";
}

TEST(ExactDepth, PlanarIsTheDistanceTimesTheAxisCosine) {
  // On the bundled atrium: planar = distance * cos(angle to the axis), each
  // exact to one rounding, so they agree to two.
  const Scene scene = load_gltf(std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb");
  PipelineOptions cpu;
  cpu.backend = Backend::cpu;
  Pipeline r(scene, cpu);
  const Camera cam = make_camera(*scene.camera, 90, 50, 0.2, -0.1);
  FrameOptions planar = exact();
  planar.planar_depth = true;
  const HitBuffer a = r.render(cam, 1, exact()).hits, b = r.render(cam, 1, planar).hits;
  size_t hits = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const size_t i = static_cast<size_t>(y) * cam.width + x;
      if (a[i].instance == RF_INVALID) continue;
      const glm::dvec3 d = exact_direction(cam, x, y);
      const double expected = static_cast<double>(a[i].z) * (-d.z / glm::length(d));
      EXPECT_NEAR(b[i].z, expected, 0x1p-22 * expected) << "pixel " << x << ", " << y;
      ++hits;
    }
  EXPECT_GT(hits, a.size() / 4);
}

}  // namespace
}  // namespace rayfold::core
