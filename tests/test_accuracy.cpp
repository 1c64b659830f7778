// The double-precision reference, and the float tracers measured against it.
#include <gtest/gtest.h>

#include <filesystem>

#include "fixtures/scene_gen.h"
#include "reference/accuracy.h"
#include "reference/double_reference.h"
#include "pipeline/pipeline.h"
#include "scene/gltf_loader.h"
#include "test_util.h"

namespace rayfold::core {
namespace {

TEST(DoubleReference, TreesLoseNothingAgainstBruteForce) {
  testing::Rng rng(17);
  size_t hits = 0;
  for (int s = 0; s < 4; ++s) {
    const Scene scene = testing::random_scene(rng, 2, 10, 120);
    const SceneData data = prepare_scene(scene);
    for (int v = 0; v < 4; ++v) {
      const Camera cam = make_camera(testing::random_camera(rng, scene.world_bounds()), 40, 30);
      const auto trees = trace_double_reference(scene, data, cam);
      const auto brute = trace_double_reference(scene, data, cam, 0, true);
      for (size_t i = 0; i < trees.size(); ++i) {
        ASSERT_EQ(trees[i].instance, brute[i].instance) << "scene " << s << " view " << v << " pixel " << i;
        ASSERT_EQ(trees[i].primitive, brute[i].primitive);
        ASSERT_EQ(trees[i].distance, brute[i].distance);
        hits += trees[i].instance != RF_INVALID;
      }
    }
  }
  EXPECT_GT(hits, 1000u);
}

TEST(DoubleReference, HandComputedDistance) {
  Scene scene;
  Mesh tri;
  tri.positions = {{-10, -10, -5}, {10, -10, -5}, {0, 10, -5}};
  tri.indices = {0, 1, 2};
  scene.meshes.push_back(tri);
  scene.instances.push_back({0, Xform(1.0), "t"});
  const SceneData data = prepare_scene(scene);
  CameraSpec spec;
  spec.vfov_degrees = 90.0;
  const Camera cam = make_camera(spec, 3, 3);
  const auto ref = trace_double_reference(scene, data, cam);
  EXPECT_EQ(ref[4].distance, 5.0);  // straight ahead
  // Pixel (2, 1): direction (2 * tan(45) / 3, 0, -1) hits z = -5 at x = 10/3.
  EXPECT_NEAR(ref[5].distance, 5.0 * std::sqrt(1.0 + 4.0 / 9.0), 1e-12);
}

// A floor and a wall a thousand times wider than the eye's height above the
// floor, seen from close by. Woop's distance (edge functions times sheared
// vertex depths) cancels there: 6e-5 relative here, 3e-4 on the Dabrovic
// Sponza's floor. The plane's distance (rf_plane_offset) keeps it near the
// float ray's own rounding, on the CPU reference and the OpenCL kernels alike.
TEST(DoubleReference, LargeTrianglesNearTheEyeKeepTheirDepth) {
  Scene scene;
  Mesh floor;
  floor.positions = {{-1000, 0, -1000}, {1000, 0, -1000}, {1000, 0, 1000}, {-1000, 0, 1000},
                     {-1000, 0, -3}, {1000, 0, -3}, {1000, 900, -3}, {-1000, 900, -3}};
  floor.indices = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7};
  scene.meshes.push_back(floor);
  scene.instances.push_back({0, Xform(1.0), "floor and wall"});
  CameraSpec spec;
  spec.eye = {0.37, 1.3, 0.21};
  spec.look_at = {3.1, 0.2, -4.3};
  spec.vfov_degrees = 75.0;
  const Camera cam = make_camera(spec, 96, 64);
  for (int variant = 0; variant < 3; ++variant) {
    PipelineOptions opt;
    opt.backend = variant == 0 ? Backend::cpu : Backend::opencl;
    opt.kernel = variant == 1 ? Kernel::tile : Kernel::single;
    const char* name = variant == 0 ? "CPU reference" : variant == 1 ? "tile kernel" : "single-ray kernel";
    Pipeline r(scene, opt);
    const auto ref = trace_double_reference(scene, r.scene_data(), cam);
    const Accuracy a = measure_accuracy(ref, r.render(cam).hits);
    std::printf("%s: relative depth error p99 %.2e, max %.2e\n", name, a.depth_p99, a.depth_max);
    EXPECT_GT(a.same_hit, 0.99) << name;
    EXPECT_LT(a.depth_max, 2e-6) << name << ": p99 " << a.depth_p99;
  }
}

// The float tracers against the reference: the figures docs/exactness.md
// quotes; the bounds only catch regressions.
TEST(DoubleReference, FloatTracersAgainstReference) {
  std::vector<std::pair<std::string, CameraSpec>> scenes;
  const std::string atrium = std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb";
  scenes.push_back({atrium, *load_gltf(atrium).camera});
  const std::string dir = testing::shared_scenes_dir();
  if (!dir.empty() && std::filesystem::exists(dir + "/conference.glb")) {
    CameraSpec c;
    c.eye = {330, 300, -300};
    c.look_at = {1000, 200, 0};
    scenes.push_back({dir + "/conference.glb", c});
  }
  for (const auto& [path, spec] : scenes) {
    const Scene scene = load_gltf(path);
    const Camera cam = make_camera(spec, 320, 180);
    Pipeline r(scene, PipelineOptions{});
    const auto ref = trace_double_reference(scene, r.scene_data(), cam);
    const Accuracy a = measure_accuracy(ref, r.render(cam).hits);
    std::printf(
        "exact float tracer vs double reference, %s: same triangle %.4f%%, hit/miss %.4f%%, relative "
        "depth error median %.2e, p99 %.2e, max %.2e\n",
        std::filesystem::path(path).filename().c_str(), 100 * a.same_hit, 100 * a.hit_miss, a.depth_median, a.depth_p99,
        a.depth_max);
    EXPECT_GT(a.same_hit, 0.995) << path;
    EXPECT_LT(a.hit_miss, 0.001) << path;
    EXPECT_LT(a.depth_median, 1e-5) << path;
  }
}

}  // namespace
}  // namespace rayfold::core
