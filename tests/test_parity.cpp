// CPU reference vs OpenCL, bit for bit, on every field of every pixel: the
// bundled default scene at full size and many random cameras over generated
// scenes.
#include <gtest/gtest.h>

#include <filesystem>

#include "fixtures/scene_gen.h"
#include "pipeline/pipeline.h"
#include "scene/gltf_loader.h"
#include "test_util.h"

namespace rayfold::core {
namespace {

PipelineOptions cpu_options() {
  PipelineOptions o;
  o.backend = Backend::cpu;
  return o;
}

TEST(Parity, DefaultSceneFullSize) {
  const std::string path = std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb";
  const Scene scene = load_gltf(path);
  ASSERT_TRUE(scene.camera.has_value());
  const Camera cam = make_camera(*scene.camera, 1280, 720);
  Pipeline cpu(scene, cpu_options());
  Pipeline cl(scene, PipelineOptions{});
  const RenderResult a = cpu.render(cam);
  const RenderResult b = cl.render(cam);
  EXPECT_EQ(testing::compare_hits(a.hits, b.hits, cam.width), "");
  size_t hits = 0;
  for (const rf_pixel_hit& h : a.hits) hits += h.instance != RF_INVALID;
  EXPECT_GT(hits, a.hits.size() / 2);
}

TEST(Parity, RandomCamerasOverGeneratedScenes) {
  testing::Rng rng(99);
  int cameras = 0;
  for (int s = 0; s < 3; ++s) {
    const Scene scene = testing::generated_atrium(1000 + s, 30 + 60 * s, 20000);
    Pipeline cpu(scene, cpu_options());
    Pipeline cl(scene, PipelineOptions{});
    for (int v = 0; v < 20; ++v, ++cameras) {
      const int w = 40 + rng.below(120), h = 30 + rng.below(90);
      const Camera cam = make_camera(testing::random_camera(rng, scene.world_bounds()), w, h);
      const RenderResult a = cpu.render(cam);
      const RenderResult b = cl.render(cam);
      EXPECT_EQ(testing::compare_hits(a.hits, b.hits, w), "") << "scene " << s << " camera " << v;
    }
  }
  EXPECT_GE(cameras, 50);
}

TEST(Parity, RandomTriangleSoupsWithMirrors) {
  testing::Rng rng(123);
  for (int s = 0; s < 4; ++s) {
    const Scene scene = testing::random_scene(rng, 3, 15, 400);
    Pipeline cpu(scene, cpu_options());
    Pipeline cl(scene, PipelineOptions{});
    for (int v = 0; v < 5; ++v) {
      const Camera cam = make_camera(testing::random_camera(rng, scene.world_bounds()), 96, 64);
      EXPECT_EQ(testing::compare_hits(cpu.render(cam).hits, cl.render(cam).hits, 96), "") << s << "/" << v;
    }
  }
}

}  // namespace
}  // namespace rayfold::core

namespace rayfold::core {
namespace {

TEST(Parity, SharedScenesSuggestedViews) {
  if (testing::shared_scenes_dir().empty())
    GTEST_SKIP() << "../shared/scenes not found (set RAYFOLD_SCENES_DIR); real scenes not tested";
  const int rendered = testing::for_each_shared_scene([](const testing::SharedView& v, const Scene& scene) {
    const Camera cam = make_camera(v.camera(), 160, 90);
    Pipeline cpu(scene, cpu_options());
    Pipeline cl(scene, PipelineOptions{});
    const RenderResult a = cpu.render(cam);
    EXPECT_EQ(testing::compare_hits(a.hits, cl.render(cam).hits, cam.width), "") << v.file;
    size_t hits = 0;
    for (const rf_pixel_hit& h : a.hits) hits += h.instance != RF_INVALID;
    EXPECT_GT(hits, a.hits.size() / 10) << v.file << ": the suggested view should see the scene";
  });
  EXPECT_GT(rendered, 0);
}

}  // namespace
}  // namespace rayfold::core
