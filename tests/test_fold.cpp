// Folding is lossless: the hit info of every fold mode equals the unfolded
// render bit for bit, on the CPU reference and on OpenCL, for the default
// scene, random cameras, odd and tiny sizes, shifted windows and real scenes.
// And the folded ray list answers every pixel exactly once with fewer rays.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>

#include "fixtures/scene_gen.h"
#include "fold/ray_list.h"
#include "fold/view_passes.h"
#include "reference/hit_compare.h"
#include "pipeline/pipeline.h"
#include "scene/gltf_loader.h"
#include "test_util.h"

namespace rayfold::core {
namespace {

const Fold kFolds[] = {Fold::y, Fold::x, Fold::xy};

PipelineOptions backend(Backend b) {
  PipelineOptions o;
  o.backend = b;
  return o;
}

FrameOptions with_fold(Fold f, bool cull = true) {
  FrameOptions o;
  o.fold = f;
  o.cull = cull;
  return o;
}

// Renders `cam` unfolded and in every fold mode on one renderer; returns ""
// when all agree bit for bit, else the first difference.
std::string fold_differences(Pipeline& r, const Camera& cam) {
  const HitBuffer none = r.render(cam, 1, with_fold(Fold::none)).hits;
  std::string out;
  for (Fold f : kFolds) {
    const std::string d = testing::compare_hits(none, r.render(cam, 1, with_fold(f)).hits, cam.width);
    if (!d.empty()) out += std::string("fold ") + fold_name(f) + ": " + d + "\n";
  }
  return out;
}

// Trial `trial`'s image for the ray-list tests: the first `small` trials up
// to small_side pixels a side, the rest up to max_w x max_h; every third
// shifted in x and every fourth in y (off-centre windows fold only in part).
struct RayListImage {
  int w, h;
  double sx, sy;  // the window's shift
  Camera cam;
};
RayListImage ray_list_image(testing::Rng& rng, int trial, int small, int small_side, int max_w, int max_h) {
  const int w = 1 + rng.below(trial < small ? small_side : max_w), h = 1 + rng.below(trial < small ? small_side : max_h);
  const double sx = trial % 3 == 0 ? rng.uniform(-1.5, 1.5) : 0.0, sy = trial % 4 == 0 ? rng.uniform(-1.5, 1.5) : 0.0;
  return {w, h, sx, sy, make_camera(CameraSpec{}, w, h, sx, sy)};
}

TEST(FoldRayList, AnswersEveryPixelExactlyOnce) {
  testing::Rng rng(8);
  for (int trial = 0; trial < 300; ++trial) {
    const auto [w, h, sx, sy, cam] = ray_list_image(rng, trial, 100, 6, 70, 50);
    for (Fold f : {Fold::none, Fold::y, Fold::x, Fold::xy}) {
      const RayList list = make_ray_list(cam.params, f);
      std::vector<int> answered(static_cast<size_t>(w) * h, 0);
      for (uint32_t e : list.entries) {
        const int x = e & RF_RAY_COORD_MASK, y = (e >> RF_RAY_COORD_BITS) & RF_RAY_COORD_MASK;
        const bool mx = e & RF_RAY_MIRROR_X, my = e & RF_RAY_MIRROR_Y;
        if (mx) {
          ASSERT_TRUE(folds_columns(f));
        }
        if (my) {
          ASSERT_TRUE(folds_rows(f));
        }
        for (int g = 0; g < 4; ++g) {
          if ((g & 1 && !mx) || (g & 2 && !my)) continue;
          const int px = g & 1 ? cam.params.xpair - x : x, py = g & 2 ? cam.params.ypair - y : y;
          ASSERT_TRUE(px >= 0 && px < w && py >= 0 && py < h) << w << "x" << h << " " << fold_name(f);
          // The partner's ray is exactly the mirror of this one.
          const int kx = 2 * x + cam.params.kx0, pkx = 2 * px + cam.params.kx0;
          const int ky = cam.params.ky0 - 2 * y, pky = cam.params.ky0 - 2 * py;
          EXPECT_EQ(g & 1 ? -kx : kx, pkx);
          EXPECT_EQ(g & 2 ? -ky : ky, pky);
          answered[static_cast<size_t>(py) * w + px]++;
        }
      }
      for (size_t i = 0; i < answered.size(); ++i)
        ASSERT_EQ(answered[i], 1) << w << "x" << h << " shift " << sx << "," << sy << " fold " << fold_name(f)
                                  << " pixel " << i;
      // Centred images: exactly ceil(w/2) columns and ceil(h/2) rows traced.
      if (sx == 0.0 && sy == 0.0) {
        const size_t cols = folds_columns(f) ? (w + 1) / 2 : w, rows = folds_rows(f) ? (h + 1) / 2 : h;
        EXPECT_EQ(list.entries.size(), cols * rows) << w << "x" << h << " " << fold_name(f);
      }
    }
  }
}

// make_ray_list counts per column and row; this builds the same list pixel
// by pixel, as documented in fold/ray_list.h: tiles row by row, in each its
// 8x8 blocks, in each its 4x4 quads, each quad row by row; a pixel traced
// unless its fold partner's ray answers it (columns: the left half traced,
// rows: the top half), and each mirror group's region grown ray by ray.
RayList ray_list_pixel_by_pixel(const rf_camera& cam, Fold f) {
  auto role = [](int k, int partner, int n, bool fold, int traced_sign) {
    if (!fold || k == 0 || partner < 0 || partner >= n) return 0;  // traced, answers itself
    return (k > 0) == (traced_sign > 0) ? 1 : -1;                  // 1: also its partner; -1: skipped
  };
  RayList list;
  list.pixels = static_cast<size_t>(cam.width) * cam.height;
  list.tiles.push_back(0);
  for (int ty = 0; ty < cam.height; ty += RF_TILE_SIDE)
    for (int tx = 0; tx < cam.width; tx += RF_TILE_SIDE) {
      for (int by = ty; by < std::min(ty + RF_TILE_SIDE, cam.height); by += 8)
        for (int bx = tx; bx < std::min(tx + RF_TILE_SIDE, cam.width); bx += 8)
          for (int qy = by; qy < std::min(by + 8, cam.height); qy += 4)
            for (int qx = bx; qx < std::min(bx + 8, cam.width); qx += 4)
              for (int y = qy; y < std::min(qy + 4, cam.height); ++y)
                for (int x = qx; x < std::min(qx + 4, cam.width); ++x) {
                  const int kx = 2 * x + cam.kx0, ky = cam.ky0 - 2 * y;
                  const int cx = role(kx, cam.xpair - x, cam.width, folds_columns(f), -1);
                  const int cy = role(ky, cam.ypair - y, cam.height, folds_rows(f), +1);
                  if (cx < 0 || cy < 0) continue;
                  list.entries.push_back(encode_ray(x, y, cx == 1, cy == 1));
                  for (int g = 0; g < RF_MIRRORS; ++g) {
                    if ((g & 1 && cx != 1) || (g & 2 && cy != 1)) continue;
                    TracedRegion& r = list.regions[g];
                    if (!list.group_used[g]) r = {kx, kx, ky, ky};
                    list.group_used[g] = true;
                    r = {std::min(r.kx_min, kx), std::max(r.kx_max, kx), std::min(r.ky_min, ky),
                         std::max(r.ky_max, ky)};
                  }
                }
      if (list.entries.size() != list.tiles.back()) list.tiles.push_back(static_cast<uint32_t>(list.entries.size()));
    }
  return list;
}

TEST(FoldRayList, IsTheDocumentedOrderTilesAndRegionsBuiltPixelByPixel) {
  testing::Rng rng(21);
  for (int trial = 0; trial < 200; ++trial) {
    const auto [w, h, sx, sy, cam] = ray_list_image(rng, trial, 50, 20, 300, 200);
    for (Fold f : {Fold::none, Fold::y, Fold::x, Fold::xy}) {
      const RayList got = make_ray_list(cam.params, f), want = ray_list_pixel_by_pixel(cam.params, f);
      const std::string what = std::to_string(w) + "x" + std::to_string(h) + " shift " + std::to_string(sx) + "," +
                               std::to_string(sy) + " fold " + fold_name(f);
      ASSERT_EQ(got.pixels, want.pixels) << what;
      ASSERT_EQ(got.entries, want.entries) << what;
      ASSERT_EQ(got.tiles, want.tiles) << what;
      for (int g = 0; g < RF_MIRRORS; ++g) {
        ASSERT_EQ(got.group_used[g], want.group_used[g]) << what << " group " << g;
        if (!want.group_used[g]) continue;
        const TracedRegion &a = got.regions[g], &b = want.regions[g];
        EXPECT_EQ(std::vector<int>({a.kx_min, a.kx_max, a.ky_min, a.ky_max}),
                  std::vector<int>({b.kx_min, b.kx_max, b.ky_min, b.ky_max}))
            << what << " group " << g;
      }
    }
  }
}

TEST(Fold, HandBuiltSymmetricCase) {
  // A triangle left of the centre only: folded in y, the right half's
  // pixels must see its mirrored copy as nothing (the right half is empty),
  // and the left half must see it; the images must match the unfolded one.
  Scene scene;
  Mesh tri;
  tri.positions = {{-3, -1, -5}, {-1, -1, -5}, {-2, 1, -5}};
  tri.indices = {0, 1, 2};
  scene.meshes.push_back(tri);
  scene.instances.push_back({0, Xform(1.0), "left"});
  Pipeline r(scene, backend(Backend::cpu));
  const Camera cam = make_camera(CameraSpec{}, 64, 32);
  const RenderResult folded = r.render(cam, 1, with_fold(Fold::y));
  size_t left = 0, right = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 64; ++x)
      if (folded.hits[y * 64 + x].instance == 0) (x < 32 ? left : right)++;
  EXPECT_GT(left, 20u);
  EXPECT_EQ(right, 0u);
  EXPECT_EQ(folded.rays, 32u * 32u);
  EXPECT_EQ(fold_differences(r, cam), "");
}

TEST(Fold, DefaultSceneFullSizeCpuAndOpenCl) {
  const Scene scene = load_gltf(std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb");
  const Camera cam = make_camera(*scene.camera, 1280, 720);
  for (Backend b : {Backend::cpu, Backend::opencl}) {
    Pipeline r(scene, backend(b));
    EXPECT_EQ(fold_differences(r, cam), "") << (b == Backend::cpu ? "cpu" : "opencl");
  }
}

TEST(Fold, OddAndTinySizes) {
  const Scene scene = load_gltf(std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb");
  Pipeline cpu(scene, backend(Backend::cpu));
  Pipeline cl(scene, backend(Backend::opencl));
  for (auto [w, h] : std::vector<std::pair<int, int>>{{1, 1}, {2, 1}, {1, 2}, {3, 3}, {2, 2}, {5, 4}, {1279, 719}}) {
    const Camera cam = make_camera(*scene.camera, w, h);
    EXPECT_EQ(fold_differences(cpu, cam), "") << w << "x" << h << " cpu";
    EXPECT_EQ(fold_differences(cl, cam), "") << w << "x" << h << " opencl";
  }
}

TEST(Fold, RandomCamerasOverGeneratedScenes) {
  testing::Rng rng(31337);
  int cameras = 0;
  for (int s = 0; s < 4; ++s) {
    const Scene scene = testing::generated_atrium(500 + s, 20 + 70 * s, 15000);
    Pipeline cpu(scene, backend(Backend::cpu));
    Pipeline cl(scene, backend(Backend::opencl));
    for (int v = 0; v < 26; ++v, ++cameras) {
      CameraSpec spec = testing::random_camera(rng, scene.world_bounds());
      if (v % 5 == 0) testing::move_eye_inside_an_instance(rng, scene, spec);
      const int w = 1 + rng.below(90), h = 1 + rng.below(70);
      const double sx = v % 3 == 0 ? rng.uniform(-0.8, 0.8) : 0.0, sy = v % 4 == 0 ? rng.uniform(-0.8, 0.8) : 0.0;
      const Camera cam = make_camera(spec, w, h, sx, sy);
      Pipeline& r = v % 2 ? cpu : cl;
      EXPECT_EQ(fold_differences(r, cam), "") << "scene " << s << " camera " << v << " " << w << "x" << h;
    }
  }
  EXPECT_GE(cameras, 100);
}

// A frame's hit buffer is neither cleared when it is made nor between
// frames (Pipeline::begin_views): each kernel, the CPU reference and every
// fold, one view or two in a pass, perspective or orthographic, with each
// of the depth and normal options, must write every pixel, misses
// included. Rendered into buffers filled with two different bytes, the
// answers agree.
TEST(Fold, EveryPixelIsWrittenIntoAnUnclearedBuffer) {
  testing::Rng rng(2718);
  const Scene scene = testing::random_scene(rng, 2, 8, 120);
  testing::ThreeWays r(scene);
  int checked = 0;
  for (int v = 0; v < 5; ++v) {
    const int w = v % 2 ? 41 : 48, h = v % 2 ? 29 : 32;  // odd sizes: a middle row and column fold onto themselves
    CameraSpec left = testing::random_camera(rng, scene.world_bounds());
    if (v == 4) {  // parallel rays, through the single-ray kernel whatever is asked
      left.orthographic = true;
      left.ymag = 0.3 * scene.world_bounds().extent()[1];
    }
    std::vector<Camera> cams{make_camera(left, w, h)};
    if (v >= 2) {  // a second eye beside the first: the same rays, another view
      CameraSpec right = left;
      const glm::dvec3 side = glm::dvec3(scene.world_bounds().extent()) * 0.05;
      right.eye += side;
      right.look_at += side;
      cams.push_back(make_camera(right, w, h));
    }
    const size_t pixels = static_cast<size_t>(w) * h * cams.size();
    for (Pipeline* renderer : {r.cpu.get(), r.single.get(), r.tile.get()})
      for (Fold f : testing::kAllFolds) {
        if (static_cast<int>(cams.size()) > max_pass_views(f)) continue;
        FrameOptions options = with_fold(f);
        const int kind = checked % 4;  // each kind meets every renderer and fold over the views
        options.exact_depth = kind == 1;
        options.planar_depth = kind == 2;
        options.normals = kind != 3;
        HitBuffer seen[2];
        for (int k = 0; k < 2; ++k) {
          RenderResult res;
          res.hits.resize(pixels);
          std::memset(static_cast<void*>(res.hits.data()), k ? 0xC3 : 0x5A, pixels * sizeof(rf_pixel_hit));
          renderer->render_views_into(res, cams, 1, options);
          ASSERT_EQ(res.hits.size(), pixels);
          seen[k] = res.hits;
        }
        size_t misses = 0;
        for (const rf_pixel_hit& h : seen[0]) misses += h.instance == RF_INVALID;
        EXPECT_GT(misses, 0u) << "the views should see past the scene too";
        EXPECT_EQ(count_differing_pixels(seen[0], seen[1]), 0u)
            << "view " << v << " fold " << fold_name(f) << ", " << cams.size() << " views a pass, options " << kind;
        ++checked;
      }
  }
  EXPECT_GE(checked, 50);
}

TEST(Fold, RandomMirroredSoupsAgainstBruteForce) {
  // Folded and culled renders equal brute force without trees or culling.
  testing::Rng rng(77);
  for (int s = 0; s < 4; ++s) {
    const Scene scene = testing::random_scene(rng, 2, 12, 150);
    Pipeline r(scene, backend(Backend::cpu));
    for (int v = 0; v < 6; ++v) {
      const Camera cam =
          make_camera(testing::random_camera(rng, scene.world_bounds()), 33 + v, 24 + v, v % 2 ? 0.3 : 0.0, 0.0);
      const std::vector<rf_pixel_hit> expected = testing::brute_force(scene, r.scene_data(), cam);
      for (Fold f : kFolds)
        EXPECT_EQ(testing::compare_hits(expected, r.render(cam, 1, with_fold(f)).hits, cam.width), "")
            << fold_name(f) << " scene " << s << " view " << v;
    }
  }
}

TEST(Fold, CullingPerGroupIsConservative) {
  const Scene scene = load_gltf(std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb");
  Pipeline r(scene, backend(Backend::cpu));
  testing::Rng rng(4);
  for (int v = 0; v < 8; ++v) {
    const Camera cam = make_camera(testing::random_camera(rng, scene.world_bounds()), 80, 45);
    for (Fold f : kFolds) {
      const RenderResult culled = r.render(cam, 1, with_fold(f, true));
      const RenderResult all = r.render(cam, 1, with_fold(f, false));
      EXPECT_EQ(testing::compare_hits(all.hits, culled.hits, cam.width), "") << fold_name(f) << " view " << v;
      EXPECT_LE(culled.instances, all.instances);
    }
  }
}

TEST(Fold, AnimatedFramesStayLossless) {
  const Scene scene = load_gltf(std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb");
  Pipeline cpu(scene, backend(Backend::cpu));
  Pipeline cl(scene, backend(Backend::opencl));
  const Camera cam = make_camera(*scene.camera, 160, 90);
  for (int frame : {0, 3, 17}) {
    FrameOptions none = with_fold(Fold::none);
    none.animate_frame = frame;
    const HitBuffer ref = cpu.render(cam, 1, none).hits;
    if (frame > 0) {
      EXPECT_NE(testing::compare_hits(ref, cpu.render(cam, 1, with_fold(Fold::none)).hits, 160), "")
          << "animation should move something in view";
    }
    for (Fold f : kFolds) {
      FrameOptions o = with_fold(f);
      o.animate_frame = frame;
      EXPECT_EQ(testing::compare_hits(ref, cpu.render(cam, 1, o).hits, 160), "") << fold_name(f) << " cpu " << frame;
      EXPECT_EQ(testing::compare_hits(ref, cl.render(cam, 1, o).hits, 160), "") << fold_name(f) << " cl " << frame;
    }
  }
}

TEST(Fold, SharedScenes) {
  if (testing::shared_scenes_dir().empty())
    GTEST_SKIP() << "../shared/scenes not found (set RAYFOLD_SCENES_DIR); real scenes not tested";
  const int rendered = testing::for_each_shared_scene([](const testing::SharedView& v, const Scene& scene) {
    Pipeline cl(scene, backend(Backend::opencl));
    EXPECT_EQ(fold_differences(cl, make_camera(v.camera(), 121, 67)), "") << v.file;
  });
  EXPECT_GT(rendered, 0);
}

}  // namespace
}  // namespace rayfold::core
