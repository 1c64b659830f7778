// Orthographic cameras: parallel rays from the image plane. Every tracer
// (CPU reference, both OpenCL kernel choices) equals the brute force bit for
// bit in every fold mode, a power-of-two scale moves only the depth, and a
// glTF file's orthographic camera renders as the file says.
#include <gtest/gtest.h>

#include <cmath>

#include "gltf_fixture.h"
#include "pipeline/pipeline.h"
#include "test_util.h"

namespace rayfold::core {
namespace {

using testing::compare_hits;

TEST(Ortho, EveryTracerEqualsTheBruteForceInEveryFold) {
  testing::Rng rng(21);
  for (int trial = 0; trial < 6; ++trial) {
    const Scene scene = testing::random_scene(rng, 3, 6, 50);
    const SceneData data = prepare_scene(scene);
    const Camera cam = make_camera(testing::random_ortho_camera(rng, scene.world_bounds()), 33 + trial, 25 + 2 * trial);
    ASSERT_TRUE(is_orthographic(cam));
    const std::vector<rf_pixel_hit> expected = testing::brute_force(scene, data, cam);
    size_t hits = 0;
    for (const rf_pixel_hit& h : expected) hits += h.instance != RF_INVALID;
    EXPECT_GT(hits, 0u) << "trial " << trial;
    for (Backend backend : {Backend::cpu, Backend::opencl})
      for (Kernel kernel : {Kernel::tile, Kernel::single}) {
        if (backend == Backend::cpu && kernel == Kernel::single) continue;
        PipelineOptions o;
        o.backend = backend;
        o.kernel = kernel;
        Pipeline r(scene, o);
        for (Fold f : {Fold::none, Fold::y, Fold::x, Fold::xy}) {
          FrameOptions fo;
          fo.fold = f;
          EXPECT_EQ(compare_hits(expected, r.render(cam, 1, fo).hits, cam.width), "")
              << "trial " << trial << " backend " << int(backend) << " kernel " << int(kernel) << " fold "
              << fold_name(f);
        }
      }
  }
}

TEST(Ortho, APowerOfTwoScaleMovesOnlyTheDepth) {
  testing::Rng rng(3);
  const Scene base = testing::random_scene(rng, 2, 5, 40);
  const CameraSpec view = testing::random_ortho_camera(rng, base.world_bounds());
  PipelineOptions o;
  o.backend = Backend::opencl;
  Pipeline r0(base, o);
  FrameOptions fo;
  fo.fold = Fold::xy;
  const auto ref = r0.render(make_camera(view, 40, 30), 1, fo).hits;
  for (int k : {-40, -3, 5, 60}) {
    Scene s = base;
    for (Instance& i : s.instances) i.world_from_object = uniform_scale(k) * i.world_from_object;
    CameraSpec v = view;
    v.eye = std::ldexp(1.0, k) * v.eye;
    v.look_at = std::ldexp(1.0, k) * v.look_at;
    v.ymag = std::ldexp(v.ymag, k);
    Pipeline r(s, o);
    const auto got = r.render(make_camera(v, 40, 30), 1, fo).hits;
    for (size_t i = 0; i < ref.size(); ++i) {
      ASSERT_EQ(got[i].instance, ref[i].instance) << "k " << k << " pixel " << i;
      ASSERT_EQ(got[i].primitive, ref[i].primitive);
      ASSERT_EQ(got[i].u, ref[i].u);
      ASSERT_EQ(got[i].nx, ref[i].nx);
      if (std::isfinite(ref[i].z)) {
        ASSERT_EQ(got[i].z, std::ldexp(ref[i].z, k)) << "k " << k << " pixel " << i;
      }
    }
  }
}

TEST(Ortho, AFilesOrthographicCameraRendersWhatItFrames) {
  // A unit triangle at z = -3 seen by an orthographic camera at the origin
  // with ymag 2: the triangle covers a known share of the image, at depth 3
  // everywhere.
  testing::GltfFile f;
  f.one_triangle();
  f.j["nodes"][0]["translation"] = {0.0, 0.0, -3.0};
  f.j["cameras"] = {
      {{"type", "orthographic"}, {"orthographic", {{"xmag", 2.0}, {"ymag", 2.0}, {"znear", 0.01}, {"zfar", 100.0}}}}};
  f.j["nodes"].push_back({{"camera", 0}, {"name", "top"}});
  f.j["scenes"] = {{{"nodes", {0, 1}}}};
  const Scene scene = load_gltf(f.write("ortho_camera"));
  ASSERT_TRUE(scene.camera.has_value());
  EXPECT_TRUE(scene.camera->orthographic);
  EXPECT_EQ(scene.camera->ymag, 2.0);
  const Camera cam = make_camera(*scene.camera, 64, 64);
  Pipeline r(scene, {});
  const auto hits = r.render(cam).hits;
  size_t n = 0;
  for (const rf_pixel_hit& h : hits)
    if (h.instance != RF_INVALID) {
      ++n;
      EXPECT_EQ(h.z, 3.0f);
    }
  // The triangle (0,0)-(1,0)-(0,1) has area 1/2 of the 4x4 view: 1/32 of
  // 4096 pixels, up to its edges' pixels.
  EXPECT_NEAR(double(n), 4096.0 / 32.0, 12.0);
}

}  // namespace
}  // namespace rayfold::core
