// Alpha masks (glTF alphaMode MASK): a masked quad in front of an opaque
// one, seen through where its texel's alpha, or its corners' interpolated
// alpha times the factor, is below the cutoff: which quad each pixel sees,
// computed here by hand; every backend, kernel and fold giving the same
// bits; ray queries seeing through it too; BLEND traced as opaque with a
// warning; scene files holding the masks.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "api/scene_state.h"
#include "bvh/scene_file.h"
#include "gltf_fixture.h"
#include "rayfold/rayfold.h"
#include "test_util.h"
#include "texture_fixture.h"

namespace {

using rayfold::core::testing::GltfFile;
using rayfold::core::testing::png;
using rayfold::core::testing::Texels;

// Two quads [-1, 1]^2 facing +z: the back one (instance 0) at z = 0,
// opaque; the front one (instance 1) at z = 0.5 with material 0, TEXCOORD_0
// (0, 0) at its top left, COLOR_0's alpha 0 on its left corners and 1 on
// its right ones when `ramp`.
struct MaskedQuads {
  GltfFile f;
  explicit MaskedQuads(bool ramp) {
    const std::vector<glm::vec3> p = {{-1, 1, 0}, {1, 1, 0}, {1, -1, 0}, {-1, -1, 0}};
    static const float kUv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    static const float kColor[16] = {1, 1, 1, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 0};
    static const uint16_t kIdx[6] = {0, 3, 2, 0, 2, 1};
    const int pos = f.positions(p), idx = f.accessor(f.view(kIdx, 12), 5123, "SCALAR", 6);
    nlohmann::json back = rayfold::core::testing::prim(pos, idx), front = back;
    front["attributes"]["TEXCOORD_0"] = f.accessor(f.view(kUv, 32), 5126, "VEC2", 4);
    if (ramp) front["attributes"]["COLOR_0"] = f.accessor(f.view(kColor, 64), 5126, "VEC4", 4);
    front["material"] = 0;
    f.j["meshes"] = {{{"name", "back"}, {"primitives", {back}}}, {{"name", "front"}, {"primitives", {front}}}};
    f.j["nodes"] = {{{"mesh", 0}, {"name", "back"}}, {{"mesh", 1}, {"name", "front"}, {"translation", {0, 0, 0.5}}}};
  }
  // A 4x4 texture whose alpha is 255 on a checkerboard's white squares, 0 elsewhere.
  void checkerboard(double cutoff) {
    Texels t{4, 4, {}};
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 4; ++x) {
        const uint8_t a = (x + y) % 2 == 0 ? 255 : 0;
        for (uint8_t b : {uint8_t(200), uint8_t(100), uint8_t(50), a}) t.rgba.push_back(b);
      }
    const std::vector<uint8_t> bytes = png(t);
    f.j["images"] = {{{"bufferView", f.view(bytes.data(), bytes.size())}, {"mimeType", "image/png"}}};
    f.j["samplers"] = {{{"magFilter", 9728}, {"minFilter", 9728}}};
    f.j["textures"] = {{{"source", 0}, {"sampler", 0}}};
    f.j["materials"] = {{{"alphaMode", "MASK"},
                         {"alphaCutoff", cutoff},
                         {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}};
  }
};

// 16x16 pixels over [-1, 1]^2 seen from +z: pixel (x, y) at texture
// coordinates ((x + 0.5) / 16, (y + 0.5) / 16), texel (x / 4, y / 4).
rayfold::Camera square_view() { return rayfold::Camera::orthographic({0, 0, 5}, {0, 0, 0}, {0, 1, 0}, 1.0, 16, 16); }

struct Way {
  rayfold::Backend backend;
  rayfold::Kernel kernel;
  const char* name;
};
const Way kWays[] = {{rayfold::Backend::cpu, rayfold::Kernel::automatic, "cpu reference"},
                     {rayfold::Backend::opencl, rayfold::Kernel::tile, "opencl tile"},
                     {rayfold::Backend::opencl, rayfold::Kernel::single, "opencl single"}};

// Every backend, kernel and fold renders `want_instance(x, y)` at each pixel.
template <class Want>
void expect_seen(const std::string& path, const rayfold::Camera& camera, Want want_instance) {
  const rayfold::Scene scene = rayfold::Scene::load(path);
  for (const Way& way : kWays) {
    rayfold::RendererOptions o;
    o.backend = way.backend;
    o.kernel = way.kernel;
    rayfold::Renderer renderer(scene, o);
    for (rayfold::Fold fold : {rayfold::Fold::none, rayfold::Fold::y, rayfold::Fold::x, rayfold::Fold::xy}) {
      const rayfold::GBuffer g = renderer.render(camera, fold);
      for (int y = 0; y < g.height; ++y)
        for (int x = 0; x < g.width; ++x)
          ASSERT_EQ(g.instance_id[static_cast<size_t>(y) * g.width + x], want_instance(x, y))
              << way.name << ", fold " << rayfold::fold_name(fold) << ", pixel " << x << ", " << y;
    }
  }
}

TEST(Alpha, ATextureMaskShowsTheQuadBehindItsClearTexels) {
  MaskedQuads q(false);
  q.checkerboard(0.5);
  expect_seen(q.f.write("alpha_checker"), square_view(),
              [](int x, int y) { return (x / 4 + y / 4) % 2 == 0 ? 1u : 0u; });
}

// The float64 reference (render_reference: rayfold-peers' accuracy) sees
// through the same texels: the masks' rule at its hit's barycentrics.
TEST(Alpha, TheFloat64ReferenceSeesThroughTheMasks) {
  MaskedQuads q(false);
  q.checkerboard(0.5);
  const rayfold::Scene scene = rayfold::Scene::load(q.f.write("alpha_reference"));
  const rayfold::ReferenceImage r = rayfold::render_reference(scene, square_view());
  for (int y = 0; y < r.height; ++y)
    for (int x = 0; x < r.width; ++x)
      ASSERT_EQ(r.instance_id[static_cast<size_t>(y) * r.width + x], (x / 4 + y / 4) % 2 == 0 ? 1u : 0u)
          << "pixel " << x << ", " << y;
}

TEST(Alpha, MergedTreesAndMixedMeshesFindTheirMasks) {
  // The front quad written at z = 0.5 in its own mesh and both nodes left
  // where they are: the two instances share one merged tree, the front's
  // triangles known by rf_tri::inst. The front mesh's second primitive, an
  // opaque quad over the bottom quarter at z = 0.75, keeps every hit (a
  // mesh of masked and opaque primitives).
  MaskedQuads q(false);
  q.checkerboard(0.5);
  const std::vector<glm::vec3> front = {{-1, 1, 0.5f}, {1, 1, 0.5f}, {1, -1, 0.5f}, {-1, -1, 0.5f}};
  const std::vector<glm::vec3> strip = {{-1, -0.5f, 0.75f}, {1, -0.5f, 0.75f}, {1, -1, 0.75f}, {-1, -1, 0.75f}};
  static const uint16_t kIdx[6] = {0, 3, 2, 0, 2, 1};
  nlohmann::json masked = q.f.j["meshes"][1]["primitives"][0];
  masked["attributes"]["POSITION"] = q.f.positions(front);
  nlohmann::json opaque =
      rayfold::core::testing::prim(q.f.positions(strip), q.f.accessor(q.f.view(kIdx, 12), 5123, "SCALAR", 6));
  opaque["material"] = 1;
  q.f.j["meshes"][1]["primitives"] = {masked, opaque};
  q.f.j["materials"].push_back({{"name", "opaque"}});
  q.f.j["nodes"][1].erase("translation");
  // Rows from 12 on lie below y = -0.5 (row 12's centre at -0.5625).
  expect_seen(q.f.write("alpha_merged"), square_view(),
              [](int x, int y) { return y >= 12 || (x / 4 + y / 4) % 2 == 0 ? 1u : 0u; });
}

TEST(Alpha, VertexAlphaTimesTheFactorAgainstTheCutoff) {
  // No texture: alpha = factor * COLOR_0's, (x + 1) / 2 across the quad.
  MaskedQuads q(true);
  q.f.j["materials"] = {
      {{"alphaMode", "MASK"}, {"alphaCutoff", 0.6}, {"pbrMetallicRoughness", {{"baseColorFactor", {1, 1, 1, 0.8}}}}}};
  // Kept where 0.8 (x + 1) / 2 >= 0.6, x >= 0.5: pixel columns from 12 on
  // (column 12's centre at x = 0.5625, column 11's at 0.4375).
  expect_seen(q.f.write("alpha_ramp"), square_view(), [](int x, int) { return x >= 12 ? 1u : 0u; });
}

TEST(Alpha, TheSameBitsInPerspectiveOnEveryBackendAndFold) {
  MaskedQuads q(true);
  q.checkerboard(0.25);
  const rayfold::Scene scene = rayfold::Scene::load(q.f.write("alpha_slanted"));
  const rayfold::Camera camera = rayfold::Camera::look_at({0.4, -2.0, 3.0}, {0, 0, 0.2}, {0, 0, 1}, 55.0, 64, 48);
  rayfold::RendererOptions cpu;
  cpu.backend = rayfold::Backend::cpu;
  rayfold::Renderer reference(scene, cpu);
  const rayfold::GBuffer want = reference.render(camera, rayfold::Fold::none);
  size_t front = 0, back = 0;
  for (uint32_t id : want.instance_id) (id == 1 ? front : id == 0 ? back : front) += id != rayfold::kMiss;
  ASSERT_GT(front, 200u);
  ASSERT_GT(back, 200u);
  for (const Way& way : kWays) {
    rayfold::RendererOptions o;
    o.backend = way.backend;
    o.kernel = way.kernel;
    rayfold::Renderer renderer(scene, o);
    for (rayfold::Fold fold : {rayfold::Fold::none, rayfold::Fold::y, rayfold::Fold::x, rayfold::Fold::xy})
      EXPECT_EQ(rayfold::count_differing_pixels(renderer.render(camera, fold), want), 0u)
          << way.name << ", fold " << rayfold::fold_name(fold);
  }
}

TEST(Alpha, RayQueriesSeeThroughTheClearTexels) {
  MaskedQuads q(false);
  q.checkerboard(0.5);
  const rayfold::Scene scene = rayfold::Scene::load(q.f.write("alpha_queries"));
  // From above each texel's centre down to z = 0.25, between the quads:
  // blocked where the texel is opaque.
  std::vector<float> origins, directions;
  std::vector<uint8_t> want;
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      origins.insert(origins.end(), {-0.75f + 0.5f * x, 0.75f - 0.5f * y, 2.0f});
      directions.insert(directions.end(), {0.0f, 0.0f, -1.75f});
      want.push_back((x + y) % 2 == 0 ? 1 : 0);
    }
  // From one point, (0, 0, 3), to a 16x16 grid of points at z = 0.25: rays
  // of one origin, enough of them to trace in tiles (the tile kernel's
  // lanes). Each crosses the front quad (z = 0.5) at 10/11 of its target.
  std::vector<float> shared, towards;
  std::vector<uint8_t> want_shared;
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 16; ++x) {
      const float cx = -1.0f + (x + 0.5f) / 8.0f, cy = 1.0f - (y + 0.5f) / 8.0f;
      const double u = (10.0 / 11.0 * cx + 1.0) / 2.0, v = (1.0 - 10.0 / 11.0 * cy) / 2.0;
      shared.insert(shared.end(), {0.0f, 0.0f, 3.0f});
      towards.insert(towards.end(), {cx, cy, -2.75f});
      want_shared.push_back((static_cast<int>(u * 4) + static_cast<int>(v * 4)) % 2 == 0 ? 1 : 0);
    }
  for (const Way& way : kWays) {
    rayfold::RendererOptions o;
    o.backend = way.backend;
    o.kernel = way.kernel;
    rayfold::Renderer renderer(scene, o);
    EXPECT_EQ(renderer.occluded(origins.data(), directions.data(), want.size(), 0.0f, 1.0f), want) << way.name;
    EXPECT_EQ(renderer.occluded(shared.data(), towards.data(), want_shared.size(), 0.0f, 1.0f), want_shared)
        << way.name << ", one origin";
  }
}

TEST(Alpha, BlendIsOpaqueWithAWarning) {
  MaskedQuads blend(false);
  blend.checkerboard(0.5);
  blend.f.j["materials"][0]["alphaMode"] = "BLEND";
  const std::string path = blend.f.write("alpha_blend");
  expect_seen(path, square_view(), [](int, int) { return 1u; });
  const rayfold::Scene scene = rayfold::Scene::load(path);
  bool named = false;
  for (const std::string& w : scene.warnings()) named |= w.find("material 0 has alphaMode BLEND") != std::string::npos;
  EXPECT_TRUE(named) << ::testing::PrintToString(scene.warnings());
}

// A masked scene as a scene file (Scene::to_bytes, rayfold-batch's trees):
// its masks travel with it, so the loaded scene renders the glTF's bits on
// every backend and fold, and after an added instance rebuilds its trees;
// tables that would send a mask lookup outside its arrays are refused.
TEST(Alpha, SceneFilesHoldTheMasks) {
  MaskedQuads q(true);
  q.checkerboard(0.25);
  const rayfold::Scene scene = rayfold::Scene::load(q.f.write("alpha_saved"));
  const rayfold::Camera camera = rayfold::Camera::look_at({0.4, -2.0, 3.0}, {0, 0, 0.2}, {0, 0, 1}, 55.0, 64, 48);
  rayfold::RendererOptions cpu;
  cpu.backend = rayfold::Backend::cpu;
  const rayfold::GBuffer want = rayfold::Renderer(scene, cpu).render(camera, rayfold::Fold::none);
  rayfold::Scene loaded = rayfold::Scene::from_bytes(scene.to_bytes(), "alpha.rfscene");
  for (const Way& way : kWays) {
    rayfold::RendererOptions o;
    o.backend = way.backend;
    o.kernel = way.kernel;
    rayfold::Renderer renderer(loaded, o);
    for (rayfold::Fold fold : {rayfold::Fold::none, rayfold::Fold::xy})
      EXPECT_EQ(rayfold::count_differing_pixels(renderer.render(camera, fold), want), 0u)
          << way.name << ", fold " << rayfold::fold_name(fold);
  }
  // Another instance of the masked mesh far away: the trees are built again
  // from the loaded meshes' masks, and the view is the same.
  const rayfold::Matrix4 away = {1, 0, 0, 50, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};  // row-major
  loaded.add_instance(1, away);
  EXPECT_EQ(rayfold::count_differing_pixels(rayfold::Renderer(loaded, cpu).render(camera, rayfold::Fold::none), want),
            0u);

  auto why = [](const std::string& b) {
    try {
      rayfold::Scene::from_bytes(b, "x.rfscene");
    } catch (const rayfold::InputError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  const rayfold::core::SceneFile file{scene.state()->scene, *scene.state()->trees, "", {}};
  ASSERT_FALSE(file.data.alpha.empty());
  auto damaged = [&](auto&& change) {
    rayfold::core::SceneFile bad = file;
    change(bad);
    return why(rayfold::core::scene_file_bytes(bad, RAYFOLD_VERSION_STRING));
  };
  EXPECT_NE(damaged([](auto& f) { f.data.alpha.index.pop_back(); }).find("do not match its trees"), std::string::npos);
  EXPECT_NE(damaged([](auto& f) {
              f.data.alpha.index[0] = static_cast<uint32_t>(f.data.alpha.tris.size());
            }).find("outside its triangles"),
            std::string::npos);
  EXPECT_NE(damaged([](auto& f) { f.data.alpha.tris[0].image = 7; }).find("image past the last"), std::string::npos);
  EXPECT_NE(damaged([](auto& f) { f.data.alpha.images[0].width = 1000; }).find("outside its texels"),
            std::string::npos);
  EXPECT_NE(damaged([](auto& f) { f.data.alpha.images[0].wrap = 3; }).find("unknown mode"), std::string::npos);
  // A zero-sized image would divide by zero in the wrap (repeat, mirror) or
  // index below the texels (clamp); tables with masks but no image at all
  // would be empty device buffers.
  EXPECT_NE(damaged([](auto& f) { f.data.alpha.images[0].width = 0; }).find("is empty"), std::string::npos);
  EXPECT_NE(damaged([](auto& f) { f.data.alpha.images[0].height = 1u << 31; }).find("is empty"), std::string::npos);
  EXPECT_NE(damaged([](auto& f) {
              f.data.alpha.images.clear();
              for (rf_alpha_tri& t : f.data.alpha.tris) t.image = RF_INVALID;
            }).find("do not match its trees"),
            std::string::npos);
  EXPECT_NE(damaged([](auto& f) {
              f.scene.alpha_images[0].width = 0;
              f.scene.alpha_images[0].alpha.clear();
            }).find("empty or wider"),
            std::string::npos);
  EXPECT_NE(damaged([](auto& f) { f.scene.meshes[1].alpha.pop_back(); }).find("do not match its triangles"),
            std::string::npos);
  EXPECT_NE(damaged([](auto& f) { f.scene.alpha_images[0].alpha.pop_back(); }).find("do not match its size"),
            std::string::npos);
  EXPECT_EQ(damaged([](auto&) {}), "no error");
}

}  // namespace
