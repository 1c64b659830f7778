// Views traced together (alignment, issue 10): every view of a pass must be
// the bits of that view rendered alone, unfolded, by the CPU reference, all
// eight channels, in every kernel and fold: stereo pairs, camera paths,
// views with nothing in common, random cameras over generated scenes and
// mirrored triangle soups, animated instances, orthographic views and every
// shared real scene.
#include <gtest/gtest.h>

#include <cmath>

#include "fold/frame.h"
#include "fold/ray_list.h"
#include "pipeline/pipeline.h"
#include "scene/animation.h"
#include "test_util.h"

namespace rayfold::core {
namespace {

// "" when every view of every pass equals that view alone; else each
// difference, naming the renderer, fold and view.
std::string aligned_differences(testing::ThreeWays& r, const std::vector<Camera>& views, int animate_frame = -1,
                                std::vector<Fold> folds = {Fold::none, Fold::y, Fold::x,
                                                               Fold::xy}) {
  std::vector<HitBuffer> alone;
  for (const Camera& v : views) alone.push_back(r.reference(v, animate_frame));
  const size_t pixels = static_cast<size_t>(views[0].width) * views[0].height;
  std::string out;
  for (Fold f : folds) {
    if (static_cast<int>(views.size()) > max_pass_views(f)) continue;
    FrameOptions o;
    o.fold = f;
    o.animate_frame = animate_frame;
    for (auto [name, renderer] :
         {std::pair<const char*, Pipeline*>{"cpu", r.cpu.get()}, {"single", r.single.get()}, {"tile", r.tile.get()}}) {
      RenderResult res;
      renderer->render_views_into(res, views, 1, o);
      if (res.hits.size() != pixels * views.size()) return std::string(name) + ": wrong hit count";
      for (size_t v = 0; v < views.size(); ++v) {
        const std::vector<rf_pixel_hit> got(res.hits.begin() + v * pixels, res.hits.begin() + (v + 1) * pixels);
        const std::string d = testing::compare_hits(alone[v], got, views[0].width);
        if (!d.empty())
          out += std::string(name) + " fold " + fold_name(f) + " view " + std::to_string(v) + " of " +
                 std::to_string(views.size()) + ": " + d + "\n";
      }
    }
  }
  return out;
}

CameraSpec look(glm::dvec3 eye, glm::dvec3 at, glm::dvec3 up = {0.0, 1.0, 0.0}, double vfov = 60.0) {
  CameraSpec s;
  s.eye = eye;
  s.look_at = at;
  s.up = up;
  s.vfov_degrees = vfov;
  return s;
}

std::vector<Camera> cameras(const std::vector<CameraSpec>& specs, int w, int h) {
  std::vector<Camera> out;
  for (const CameraSpec& s : specs) out.push_back(make_camera(s, w, h));
  return out;
}

// A parallel-axis stereo pair around spec, baseline apart.
std::vector<CameraSpec> stereo(const CameraSpec& spec, double baseline) {
  const glm::dvec3 right(make_camera(spec, 8, 8).world_from_camera[0]);
  std::vector<CameraSpec> out;
  for (double sign : {-0.5, 0.5}) {
    CameraSpec e = spec;
    e.eye += sign * baseline * right;
    e.look_at += sign * baseline * right;
    out.push_back(e);
  }
  return out;
}

// n frames orbiting the box's centre at the given distance and height.
std::vector<CameraSpec> orbit(const Aabb& b, int n, double radius, double height) {
  const glm::dvec3 c = (glm::dvec3(b.lo) + glm::dvec3(b.hi)) * 0.5;
  std::vector<CameraSpec> out;
  for (int k = 0; k < n; ++k) {
    const double a = 2.0 * M_PI * k / n;
    out.push_back(look(c + glm::dvec3(radius * std::cos(a), height, radius * std::sin(a)), c));
  }
  return out;
}

// A generated scene's bounds, their diagonal and centre, for placing views.
struct Placed {
  Aabb bounds;
  double size;
  glm::dvec3 centre;
  explicit Placed(const Scene& scene)
      : bounds(scene.world_bounds()),
        size(glm::length(glm::dvec3(bounds.extent()))),
        centre((glm::dvec3(bounds.lo) + glm::dvec3(bounds.hi)) * 0.5) {}
};

TEST(Align, StereoPairsEqualEachEyeAlone) {
  const Scene scene = testing::generated_atrium(7, 60, 20000);
  testing::ThreeWays r(scene);
  testing::Rng rng(5);
  const double size = glm::length(glm::dvec3(scene.world_bounds().extent()));
  for (int k = 0; k < 4; ++k) {
    const CameraSpec centre = testing::random_camera(rng, scene.world_bounds());
    // 64 mm at human scale, for a scene about 20 m across; and a wide one.
    for (double baseline : {0.0032 * size, 0.1 * size})
      EXPECT_EQ(aligned_differences(r, cameras(stereo(centre, baseline), 64, 48)), "") << k << " " << baseline;
  }
}

TEST(Align, CameraPathsOrbitDollyAndRoll) {
  const Scene scene = testing::generated_atrium(11, 80, 30000);
  testing::ThreeWays r(scene);
  const Placed p(scene);
  const Aabb& b = p.bounds;
  const double size = p.size;
  const glm::dvec3 c = p.centre;
  EXPECT_EQ(aligned_differences(r, cameras(orbit(b, 8, 0.4 * size, 0.1 * size), 48, 36)), "") << "orbit";
  std::vector<CameraSpec> dolly, roll;
  for (int k = 0; k < 8; ++k) {
    dolly.push_back(look(c + glm::dvec3(0.0, 0.05 * size, (0.6 - 0.07 * k) * size), c));
    const double a = 0.3 * k;
    roll.push_back(look(c + glm::dvec3(0.3 * size, 0.1 * size, 0.3 * size), c, {std::sin(a), std::cos(a), 0.0}));
  }
  EXPECT_EQ(aligned_differences(r, cameras(dolly, 47, 33)), "") << "dolly, odd sizes";
  EXPECT_EQ(aligned_differences(r, cameras(roll, 40, 40)), "") << "roll";
}

TEST(Align, ViewsWithNothingInCommon) {
  // Opposite directions, a view from far outside, one that sees nothing at
  // all: their copies share no part of the top level.
  const Scene scene = testing::generated_atrium(3, 50, 20000);
  testing::ThreeWays r(scene);
  const Placed p(scene);
  const double size = p.size;
  const glm::dvec3 c = p.centre;
  const std::vector<CameraSpec> specs = {
      look(c, c + glm::dvec3(1, 0, 0)), look(c, c - glm::dvec3(1, 0, 0)), look(c + glm::dvec3(0, 0, 10 * size), c),
      look(c + glm::dvec3(0, 0, 3 * size), c + glm::dvec3(0, 0, 4 * size))};  // looking away
  EXPECT_EQ(aligned_differences(r, cameras(specs, 56, 40)), "");
}

TEST(Align, RandomCamerasOverGeneratedScenesAndMirroredSoups) {
  testing::Rng rng(2024);
  int passes = 0;
  for (int s = 0; s < 4; ++s) {
    const Scene scene =
        s % 2 == 0 ? testing::generated_atrium(300 + s, 40 + 30 * s, 15000) : testing::random_scene(rng, 3, 12, 300);
    testing::ThreeWays r(scene);
    for (int k = 0; k < 3; ++k, ++passes) {
      const int n = 2 + rng.below(7), w = 17 + rng.below(50), h = 9 + rng.below(40);
      const double vfov = 20.0 + rng.uniform(0.0, 100.0);
      std::vector<CameraSpec> specs;
      for (int v = 0; v < n; ++v) {
        CameraSpec spec = testing::random_camera(rng, scene.world_bounds());
        spec.vfov_degrees = vfov;  // one intrinsics per pass
        specs.push_back(spec);
      }
      EXPECT_EQ(aligned_differences(r, cameras(specs, w, h)), "") << "scene " << s << " pass " << k;
    }
  }
  EXPECT_GE(passes, 12);
}

TEST(Align, SixteenViewsAndThirtyTwoGroups) {
  // The most one pass holds: 32 views unfolded, 16 with one mirror, 8 with
  // both (32 groups each); aligned_differences skips what would not fit.
  const Scene scene = testing::generated_atrium(21, 40, 10000);
  testing::ThreeWays r(scene);
  const Placed p(scene);
  const Aabb& b = p.bounds;
  const double size = p.size;
  for (int n : {8, 16, 32})
    EXPECT_EQ(aligned_differences(r, cameras(orbit(b, n, 0.35 * size, 0.05 * size), 24, 16)), "") << n << " views";
  EXPECT_EQ(max_pass_views(Fold::none), 32);
  EXPECT_EQ(max_pass_views(Fold::y), 16);
  EXPECT_EQ(max_pass_views(Fold::xy), 8);
}

TEST(Align, AnimatedInstances) {
  const Scene scene = testing::generated_atrium(8, 40, 15000);
  size_t animated = 0;
  for (size_t i = 0; i < scene.instances.size(); ++i) animated += is_animated(i);
  ASSERT_GT(animated, 0u);
  testing::ThreeWays r(scene);
  const Placed p(scene);
  const Aabb& b = p.bounds;
  const double size = p.size;
  for (int frame : {0, 5, 17})
    EXPECT_EQ(aligned_differences(r, cameras(orbit(b, 4, 0.3 * size, 0.1 * size), 40, 30), frame), "") << frame;
}

TEST(Align, OrthographicViewsAlignWithinOneTraceExponent) {
  const Scene scene = testing::generated_atrium(4, 40, 15000);
  testing::ThreeWays r(scene);
  const Placed p(scene);
  const Aabb& b = p.bounds;
  const double size = p.size;
  // One eye turning: the same distances to the scene, one trace exponent.
  const glm::dvec3 c = p.centre;
  std::vector<CameraSpec> specs;
  for (const CameraSpec& s : orbit(b, 4, 0.3 * size, 0.1 * size)) {
    CameraSpec turned = look(c + glm::dvec3(0.0, 0.1 * size, 0.6 * size), s.eye);
    turned.orthographic = true;
    turned.ymag = 0.2 * size;
    specs.push_back(turned);
  }
  const std::vector<Camera> views = cameras(specs, 40, 30);
  const SceneData& data = r.cpu->scene_data();
  for (const Camera& v : views) ASSERT_TRUE(can_align(data, views[0], v));
  EXPECT_EQ(aligned_differences(r, views), "");
  // An eye 2^4 times farther has another exponent: its rays start elsewhere.
  CameraSpec far = specs[0];
  far.eye = far.look_at + (far.eye - far.look_at) * 16.0;
  EXPECT_FALSE(can_align(data, views[0], make_camera(far, 40, 30)));
  // Perspective views with other intrinsics never align.
  EXPECT_FALSE(can_align(data, make_camera(look({0, 0, 5}, {0, 0, 0}), 40, 30),
                         make_camera(look({0, 0, 5}, {0, 0, 0}, {0, 1, 0}, 50.0), 40, 30)));
}

TEST(Align, SharedScenesStereoAndOrbit) {
  if (testing::shared_scenes_dir().empty())
    GTEST_SKIP() << "../shared/scenes not found (set RAYFOLD_SCENES_DIR); real scenes not tested";
  const int n = testing::for_each_shared_scene([](const testing::SharedView& v, const Scene& scene) {
    testing::ThreeWays r(scene);
    const CameraSpec spec = v.camera();
    const double dist = glm::length(spec.look_at - spec.eye);
    EXPECT_EQ(aligned_differences(r, cameras(stereo(spec, 0.03 * dist), 64, 36)), "") << v.file << " stereo";
    std::vector<CameraSpec> path;
    for (int k = 0; k < 4; ++k) {
      CameraSpec s = spec;
      const glm::dvec3 right(make_camera(spec, 8, 8).world_from_camera[0]);
      s.eye += (0.05 * k * dist) * right;
      path.push_back(s);
    }
    EXPECT_EQ(aligned_differences(r, cameras(path, 48, 27), -1, {Fold::none, Fold::xy}), "")
        << v.file << " path";
  });
  EXPECT_GT(n, 0);
}

}  // namespace
}  // namespace rayfold::core

namespace rayfold::core {
namespace {

TEST(Align, SampledTilesAreEveryStrideThTileWhole) {
  const Camera cam = make_camera(look({0, 0, 5}, {0, 0, 0}), 100, 70);
  for (Fold f : {Fold::none, Fold::xy}) {
    const RayList rays = make_ray_list(cam.params, f);
    for (size_t stride : {1, 3, 8}) {
      const RayList s = sample_tiles(rays, stride, 1);
      const size_t tiles = rays.tiles.size() - 1;  // sampled from tile 1 on
      ASSERT_EQ(s.tiles.size() - 1, (tiles - 2) / stride + 1) << stride;
      for (size_t k = 0; k + 1 < s.tiles.size(); ++k) {
        const size_t t = 1 + k * stride;
        ASSERT_EQ(s.tiles[k + 1] - s.tiles[k], rays.tiles[t + 1] - rays.tiles[t]);
        EXPECT_TRUE(std::equal(rays.entries.begin() + rays.tiles[t], rays.entries.begin() + rays.tiles[t + 1],
                               s.entries.begin() + s.tiles[k]))
            << "tile " << t;
      }
    }
  }
}

TEST(Align, AutomaticChoicesPredictEveryCandidateAndRenderTheSameBits) {
  const Scene scene = testing::generated_atrium(13, 40, 15000);
  const Placed p(scene);
  const Aabb& b = p.bounds;
  const double size = p.size;
  const std::vector<Camera> views = cameras(orbit(b, 4, 0.3 * size, 0.1 * size), 64, 40);
  testing::ThreeWays r(scene);
  for (Pipeline* renderer : {r.cpu.get(), r.tile.get()}) {
    const AutoChoice c = choose_fastest(*renderer, views, {Fold::none, Fold::xy},
                                        {KernelKind::tile, KernelKind::single}, {1, RF_GROUP_LIMIT});
    // The kernels are probed first; one predicted more than twice as slow
    // keeps only that prediction.
    ASSERT_TRUE(c.predictions.size() == 8u || c.predictions.size() == 5u) << c.predictions.size();
    for (size_t k = 0; k < c.predictions.size(); ++k) {
      const Prediction& p = c.predictions[k];
      EXPECT_GT(p.trace_ms, 0.0) << choice_name(p.choice);
      EXPECT_GE(p.update_ms, 0.0);
      EXPECT_TRUE(p.choice.align == 1 || p.choice.align == 4) << "align is the pass size: " << p.choice.align;
      if (k > 0) {
        EXPECT_LE(c.predictions[k - 1].total_ms(), p.total_ms()) << "fastest first";
      }
    }
    EXPECT_EQ(choice_name(c.best), choice_name(c.predictions[0].choice));
    // Whatever was picked traces the same bits as each view alone.
    FrameOptions o;
    o.fold = c.best.fold;
    RenderResult res;
    renderer->render_views_into(res, views, 1, o);
    for (size_t v = 0; v < views.size(); ++v)
      EXPECT_EQ(testing::compare_hits(r.reference(views[v]), view_result(res, v).hits, 64), "") << v;
  }
}

}  // namespace
}  // namespace rayfold::core
