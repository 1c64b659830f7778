// The G-buffer's material channels (base_color, metallic_roughness,
// emissive) and labels, against values computed here by hand from the
// glTF written here: texels read at level 0 through nearest sampling, mip
// levels of a checkerboard the ray cone picks, KHR_texture_transform with
// wrap modes, node extras; and the errors a broken image gives.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "api/scene_state.h"
#include "api_fixture.h"
#include "gltf_fixture.h"
#include "rayfold/rayfold.h"
#include "test_util.h"
#include "texture_fixture.h"

namespace {

using rayfold::core::testing::GltfFile;
using rayfold::core::testing::pattern;
using rayfold::core::testing::png;
using rayfold::core::testing::png16;
using rayfold::core::testing::Texels;

std::string base64(const std::vector<uint8_t>& bytes) {
  static const char* kDigits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const size_t n = std::min<size_t>(3, bytes.size() - i);
    uint32_t word = 0;
    for (size_t k = 0; k < 3; ++k) word = (word << 8) | (k < n ? bytes[i + k] : 0);
    for (size_t k = 0; k < 4; ++k) out += k <= n ? kDigits[(word >> (18 - 6 * k)) & 63] : '=';
  }
  return out;
}

// IEC 61966-2-1, written here from the standard.
double srgb_decoded(uint8_t b) {
  const double c = b / 255.0;
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

// The quad [-1, 1]^2 at z = 0 facing +z, texture coordinates (0, 0) at its
// top-left corner (world (-1, 1)) to (1, 1) at its bottom right: seen by
// an orthographic camera on +z, pixel (x, y)'s centre has u = (x + 0.5) / n
// over n pixels across the quad.
struct TexturedQuad {
  GltfFile f;
  int mesh_primitive_material = 0;
  explicit TexturedQuad(bool with_texcoords = true) {
    const std::vector<glm::vec3> p = {{-1, 1, 0}, {1, 1, 0}, {1, -1, 0}, {-1, -1, 0}};
    static const float kUv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    static const float kColor[16] = {0.5f, 0.25f, 1, 1, 0.5f, 0.25f, 1, 1, 0.5f, 0.25f, 1, 1, 0.5f, 0.25f, 1, 1};
    static const uint16_t kIdx[6] = {0, 3, 2, 0, 2, 1};
    const int pos = f.positions(p);
    nlohmann::json prim = rayfold::core::testing::prim(pos, f.accessor(f.view(kIdx, 12), 5123, "SCALAR", 6));
    if (with_texcoords) prim["attributes"]["TEXCOORD_0"] = f.accessor(f.view(kUv, 32), 5126, "VEC2", 4);
    prim["attributes"]["COLOR_0"] = f.accessor(f.view(kColor, 64), 5126, "VEC4", 4);
    prim["material"] = 0;
    f.j["meshes"] = {{{"name", "quad"}, {"primitives", {prim}}}};
    f.j["nodes"] = {{{"mesh", 0}, {"name", "quad"}}};
  }
  // An image in a buffer view; returns its index.
  int image(const std::vector<uint8_t>& bytes, const char* mime = "image/png") {
    f.j["images"].push_back({{"bufferView", f.view(bytes.data(), bytes.size())}, {"mimeType", mime}});
    return static_cast<int>(f.j["images"].size() - 1);
  }
  int texture(int image, nlohmann::json sampler) {
    f.j["samplers"].push_back(std::move(sampler));
    f.j["textures"].push_back({{"source", image}, {"sampler", f.j["samplers"].size() - 1}});
    return static_cast<int>(f.j["textures"].size() - 1);
  }
};

const nlohmann::json kNearestSampler = {{"magFilter", 9728}, {"minFilter", 9728}};

// Looking at the quad from +z, moved by `shift` along x and y.
rayfold::Camera quad_camera(double half_height, int pixels, double shift = 0.0) {
  return rayfold::Camera::orthographic({shift, shift, 5}, {shift, shift, 0}, {0, 1, 0}, half_height, pixels, pixels);
}

constexpr double kVertexColor[4] = {0.5, 0.25, 1.0, 1.0};

// |got - want| within 2 ulps of float at want's scale (at least 1).
void expect_close(float got, double want, const char* what, size_t pixel) {
  ASSERT_LE(std::fabs(got - want), 2 * 0x1p-24 * std::max(1.0, std::fabs(want)))
      << what << " at pixel " << pixel << ": got " << got << ", want " << want;
}

constexpr unsigned kMaterialChannels = rayfold::kBaseColor | rayfold::kMetallicRoughness | rayfold::kEmissive;

TEST(Materials, TexelsFactorsAndVertexColoursAtLevelZero) {
  TexturedQuad q;
  const Texels colour = pattern(8, 8, 7), data = pattern(8, 8, 11);
  const int base = q.texture(q.image(png(colour)), kNearestSampler);
  // The metallic-roughness image as a data: URI, which tinygltf keeps nowhere else.
  q.f.j["images"].push_back({{"uri", "data:image/png;base64," + base64(png(data))}});
  const int mr = q.texture(static_cast<int>(q.f.j["images"].size() - 1), kNearestSampler);
  q.f.j["extensionsUsed"] = {"KHR_materials_emissive_strength"};
  q.f.j["materials"] = {{{"pbrMetallicRoughness",
                          {{"baseColorFactor", {0.8, 0.6, 1.0, 0.5}},
                           {"baseColorTexture", {{"index", base}}},
                           {"metallicFactor", 0.5},
                           {"roughnessFactor", 0.75},
                           {"metallicRoughnessTexture", {{"index", mr}}}}},
                         {"emissiveFactor", {1.0, 0.5, 0.25}},
                         {"emissiveTexture", {{"index", base}}},
                         {"extensions", {{"KHR_materials_emissive_strength", {{"emissiveStrength", 4.0}}}}}}};
  const std::string path = q.f.write("materials_level0");
  const rayfold::Scene scene = rayfold::Scene::load(path);
  rayfold::Renderer renderer(scene);
  // 8 pixels across the quad: one texel a pixel, level of detail 0.
  const rayfold::GBuffer g = renderer.render(quad_camera(1.0, 8), rayfold::Fold::none, kMaterialChannels);
  ASSERT_EQ(g.hits, 64u);
  EXPECT_TRUE(g.warnings.empty()) << testing::PrintToString(g.warnings);
  const double factor[4] = {0.8, 0.6, 1.0, 0.5};
  const double emissive[3] = {1.0, 0.5, 0.25};
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) {
      const size_t i = static_cast<size_t>(y) * 8 + x;
      const uint8_t* c = colour.at(x, y);
      const uint8_t* d = data.at(x, y);
      for (int k = 0; k < 4; ++k) {
        const double texel = k < 3 ? srgb_decoded(c[k]) : c[3] / 255.0;
        expect_close(g.base_color[4 * i + k], factor[k] * kVertexColor[k] * texel, "base_color", i);
      }
      expect_close(g.metallic_roughness[2 * i], 0.5 * (d[2] / 255.0), "metallic", i);
      expect_close(g.metallic_roughness[2 * i + 1], 0.75 * (d[1] / 255.0), "roughness", i);
      for (int k = 0; k < 3; ++k)
        expect_close(g.emissive[3 * i + k], emissive[k] * srgb_decoded(c[k]) * 4.0, "emissive", i);
    }
  // Misses are 0; the default material (white, metallic and rough) where
  // a primitive names none.
  const rayfold::GBuffer wide = renderer.render(quad_camera(2.0, 8), rayfold::Fold::none, kMaterialChannels);
  EXPECT_EQ(wide.base_color[0], 0.0f);
  EXPECT_EQ(wide.emissive[0], 0.0f);
  q.f.j["meshes"][0]["primitives"][0].erase("material");
  const rayfold::Scene plain = rayfold::Scene::load(q.f.write("materials_default"));
  rayfold::Renderer r2(plain);
  const rayfold::GBuffer d = r2.render(quad_camera(1.0, 8), rayfold::Fold::none, kMaterialChannels);
  for (size_t i = 0; i < 64; ++i) {
    for (int k = 0; k < 4; ++k) ASSERT_EQ(d.base_color[4 * i + k], static_cast<float>(kVertexColor[k])) << i;
    ASSERT_EQ(d.metallic_roughness[2 * i], 1.0f);
    ASSERT_EQ(d.emissive[3 * i], 0.0f);
  }
}

TEST(Materials, TheRayConePicksTheMipLevel) {
  // A checkerboard of black and white texels: every texel of level 1 and
  // below is the sRGB byte nearest linear 0.5.
  Texels checker{32, 32, std::vector<uint8_t>(32 * 32 * 4)};
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x)
      for (int k = 0; k < 4; ++k) checker.rgba[(y * 32 + x) * 4 + k] = k == 3 ? 255 : ((x + y) % 2 ? 255 : 0);
  int grey = 0;
  for (int b = 0; b < 256; ++b)
    if (std::fabs(srgb_decoded(b) - 0.5) < std::fabs(srgb_decoded(grey) - 0.5)) grey = b;
  struct Case {
    int min_filter;
    double half_height;  // of 8 pixels: a pixel is half_height / 4 wide, the quad 2 wide and 32 texels
    double want;         // NaN: the texel itself
  };
  const Case cases[] = {
      {9987, 1.0, srgb_decoded(grey)},  // LINEAR_MIPMAP_LINEAR at lod 2 exactly (4 texels a pixel): level 2
      {9984, 1.0, srgb_decoded(grey)},  // NEAREST_MIPMAP_NEAREST: level ceil(2.5) - 1 = 2
      {9728, 1.0, NAN},                 // NEAREST: level 0 however far
      {9987, 0.125, NAN},               // magnified (lod -1): level 0 through the mag filter
  };
  for (const Case& c : cases) {
    TexturedQuad q;
    const int tex = q.texture(q.image(png(checker)), {{"magFilter", 9728}, {"minFilter", c.min_filter}});
    q.f.j["materials"] = {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", tex}}}}}}};
    const rayfold::Scene scene = rayfold::Scene::load(q.f.write("materials_mips"));
    rayfold::Renderer renderer(scene);
    // Moved off the texel grid, so that no pixel centre falls on a texel's edge.
    const rayfold::GBuffer g = renderer.render(quad_camera(c.half_height, 8, c.half_height / 100), rayfold::Fold::none,
                                               rayfold::kBaseColor | rayfold::kTexcoord);
    ASSERT_EQ(g.hits, 64u);
    for (size_t i = 0; i < 64; ++i) {
      double want = c.want;
      if (std::isnan(want)) {
        const int tx = static_cast<int>(std::floor(g.texcoord[2 * i] * 32.0));
        const int ty = static_cast<int>(std::floor(g.texcoord[2 * i + 1] * 32.0));
        want = srgb_decoded(checker.at(tx, ty)[0]);
      }
      for (int k = 0; k < 3; ++k) expect_close(g.base_color[4 * i + k], kVertexColor[k] * want, "base_color", i);
    }
  }
  // Between levels: NEAREST_MIPMAP_LINEAR at lod 1/2 (a pixel sqrt(2) texels
  // wide) weighs level 0's texel and level 1's grey by the lod's fraction.
  TexturedQuad q;
  const int tex = q.texture(q.image(png(checker)), {{"magFilter", 9728}, {"minFilter", 9986}});
  q.f.j["materials"] = {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", tex}}}}}}};
  const rayfold::Scene scene = rayfold::Scene::load(q.f.write("materials_trilinear"));
  rayfold::Renderer renderer(scene);
  const double half_height = std::sqrt(2.0) / 4, lod = std::log2(4 * half_height);
  const rayfold::GBuffer g = renderer.render(quad_camera(half_height, 8, 0.013), rayfold::Fold::none,
                                             rayfold::kBaseColor | rayfold::kTexcoord);
  ASSERT_EQ(g.hits, 64u);
  for (size_t i = 0; i < 64; ++i) {
    const int tx = static_cast<int>(std::floor(g.texcoord[2 * i] * 32.0));
    const int ty = static_cast<int>(std::floor(g.texcoord[2 * i + 1] * 32.0));
    const double want = (1.0 - lod) * srgb_decoded(checker.at(tx, ty)[0]) + lod * srgb_decoded(grey);
    expect_close(g.base_color[4 * i], kVertexColor[0] * want, "trilinear base_color", i);
  }
}

TEST(Materials, TextureTransformAndWrapModes) {
  // KHR_texture_transform scales by 2 and moves by 0.3 (2.4 texels): the
  // quad reads the image twice over, mirrored along u, clamped along v.
  TexturedQuad q;
  const Texels colour = pattern(8, 8, 3);
  const int tex =
      q.texture(q.image(png(colour)), {{"magFilter", 9728}, {"minFilter", 9728}, {"wrapS", 33648}, {"wrapT", 33071}});
  q.f.j["extensionsUsed"] = {"KHR_texture_transform"};
  nlohmann::json info = {{"index", tex}};
  info["extensions"]["KHR_texture_transform"] = {{"offset", {0.3, 0.3}}, {"scale", {2.0, 2.0}}};
  q.f.j["materials"] = nlohmann::json::array();
  q.f.j["materials"].push_back({{"pbrMetallicRoughness", {{"baseColorTexture", info}}}});
  const rayfold::Scene scene = rayfold::Scene::load(q.f.write("materials_transform"));
  rayfold::Renderer renderer(scene);
  const rayfold::GBuffer g =
      renderer.render(quad_camera(1.0, 8), rayfold::Fold::none, rayfold::kBaseColor | rayfold::kTexcoord);
  ASSERT_EQ(g.hits, 64u);
  for (size_t i = 0; i < 64; ++i) {
    // Texel indices by hand: mirrored repeat over 16, clamped to 0..7.
    const double u = 2.0 * g.texcoord[2 * i] + 0.3, v = 2.0 * g.texcoord[2 * i + 1] + 0.3;
    int tx = static_cast<int>(std::floor(u * 8)) % 16;
    if (tx >= 8) tx = 15 - tx;
    const int ty = std::min(7, static_cast<int>(std::floor(v * 8)));
    for (int k = 0; k < 3; ++k)
      expect_close(g.base_color[4 * i + k], kVertexColor[k] * srgb_decoded(colour.at(tx, ty)[k]), "base_color", i);
  }
}

TEST(Materials, ARotatedTransformAsTheExtensionWritesIt) {
  // offset (0.3, 0.7), rotation pi/2, scale (2, 3): u' = cos 2u + sin 3v + 0.3, v' = -sin 2u + cos 3v + 0.7
  // (KHR_texture_transform's matrix, translation * rotation * scale).
  TexturedQuad q;
  const Texels colour = pattern(8, 8, 9);
  const int tex = q.texture(q.image(png(colour)), kNearestSampler);
  const double pi = std::acos(-1.0);
  nlohmann::json info = {{"index", tex}};
  info["extensions"]["KHR_texture_transform"] = {{"offset", {0.3, 0.7}}, {"rotation", pi / 2}, {"scale", {2.0, 3.0}}};
  q.f.j["materials"] = nlohmann::json::array();
  q.f.j["materials"].push_back({{"pbrMetallicRoughness", {{"baseColorTexture", info}}}});
  const rayfold::Scene scene = rayfold::Scene::load(q.f.write("materials_rotation"));
  rayfold::Renderer renderer(scene);
  const rayfold::GBuffer g =
      renderer.render(quad_camera(1.0, 8), rayfold::Fold::none, rayfold::kBaseColor | rayfold::kTexcoord);
  ASSERT_EQ(g.hits, 64u);
  for (size_t i = 0; i < 64; ++i) {
    const double u = g.texcoord[2 * i], v = g.texcoord[2 * i + 1];
    const double tu = std::cos(pi / 2) * 2 * u + std::sin(pi / 2) * 3 * v + 0.3;
    const double tv = -std::sin(pi / 2) * 2 * u + std::cos(pi / 2) * 3 * v + 0.7;
    const int tx = ((static_cast<int>(std::floor(tu * 8)) % 8) + 8) % 8;  // REPEAT
    const int ty = ((static_cast<int>(std::floor(tv * 8)) % 8) + 8) % 8;
    for (int k = 0; k < 3; ++k)
      expect_close(g.base_color[4 * i + k], kVertexColor[k] * srgb_decoded(colour.at(tx, ty)[k]), "base_color", i);
  }
}

TEST(Materials, LabelsComeFromTheNearestLabelledNode) {
  TexturedQuad q;
  // A room holding a chair and a table without extras of its own, and a
  // lamp outside it; each a copy of the quad, side by side.
  q.f.j["nodes"] = {{{"name", "room"}, {"children", {1, 2}}, {"extras", {{"category", "room"}, {"id", 4}}}},
                    {{"mesh", 0}, {"name", "chair"}, {"translation", {-3, 0, 0}}, {"extras", {{"category", "chair"}}}},
                    {{"mesh", 0}, {"name", "table"}, {"translation", {0, 0, 0}}},
                    {{"mesh", 0}, {"name", "lamp"}, {"translation", {3, 0, 0}}, {"extras", {{"watts", 60}}}}};
  q.f.j["scenes"] = {{{"nodes", {0, 3}}}};
  const std::string path = q.f.write("materials_labels");
  rayfold::LoadOptions keyed;
  keyed.label_key = "category";
  const rayfold::Scene scene = rayfold::Scene::load(path, keyed);
  EXPECT_EQ(scene.labels(), (std::vector<std::string>{"", "chair", "room"}));
  rayfold::Renderer renderer(scene);
  const rayfold::Camera camera = rayfold::Camera::orthographic({0, 0, 5}, {0, 0, 0}, {0, 1, 0}, 2.0, 64, 32);
  const rayfold::GBuffer g = renderer.render(camera, rayfold::Fold::none, rayfold::kLabel | rayfold::kInstanceId);
  const std::vector<std::string> names = scene.instance_names();
  const std::map<std::string, uint32_t> want = {{"chair", 1}, {"table", 2}, {"lamp", 0}};
  std::set<uint32_t> seen;
  for (size_t i = 0; i < g.label.size(); ++i) {
    if (g.instance_id[i] == rayfold::kMiss) {
      ASSERT_EQ(g.label[i], rayfold::kMiss) << i;
      continue;
    }
    ASSERT_EQ(g.label[i], want.at(names.at(g.instance_id[i]))) << names[g.instance_id[i]] << " at pixel " << i;
    seen.insert(g.label[i]);
  }
  EXPECT_EQ(seen.size(), 3u);
  // Without a key the whole extras value, as JSON.
  const rayfold::Scene whole = rayfold::Scene::load(path);
  EXPECT_EQ(whole.labels(), (std::vector<std::string>{"", "{\"category\":\"chair\"}",
                                                      "{\"category\":\"room\",\"id\":4}", "{\"watts\":60}"}));
  // The table goes into the EXR's header.
  const std::string exr = (rayfold::core::testing::temp_dir() / "materials_labels.exr").string();
  rayfold::write_exr(exr, g, camera, scene);
  const rayfold::GBuffer back = rayfold::read_exr(exr);
  EXPECT_EQ(back.label, g.label);
}

TEST(Materials, BrokenImagesAreErrorsNamingThemAndMissingCoordinatesAWarning) {
  auto render_error = [](const std::string& path) {
    const rayfold::Scene scene = rayfold::Scene::load(path);  // nothing decoded yet
    rayfold::Renderer renderer(scene);
    std::string first = "no error";
    // Asked again, the same error: nothing half-read stands in for the material.
    for (int attempt = 0; attempt < 2; ++attempt) try {
        renderer.render(quad_camera(1.0, 8), rayfold::Fold::none, rayfold::kBaseColor);
        return std::string("no error on attempt ") + std::to_string(attempt + 1);
      } catch (const rayfold::InputError& e) {
        if (attempt == 0) first = e.what();
        if (attempt == 1 && first != e.what()) return "another error the second time: " + std::string(e.what());
      }
    return first;
  };
  {
    TexturedQuad q;
    q.f.j["images"] = {{{"uri", "missing.png"}, {"name", "wood"}}};
    q.f.j["textures"] = {{{"source", 0}}};
    q.f.j["materials"] = {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}};
    const std::string path = q.f.write("materials_missing_image");
    const std::string e = render_error(path);
    EXPECT_NE(e.find(path), std::string::npos) << e;
    EXPECT_NE(e.find("image 0 ('wood')"), std::string::npos) << e;
    EXPECT_NE(e.find("missing.png"), std::string::npos) << e;
    // A render without material channels never reads it.
    const rayfold::Scene scene = rayfold::Scene::load(path);
    rayfold::Renderer renderer(scene);
    EXPECT_EQ(renderer.render(quad_camera(1.0, 8), rayfold::Fold::none, rayfold::kDepth).hits, 64u);
  }
  {
    TexturedQuad q;
    const std::vector<uint8_t> webp = {'R', 'I', 'F', 'F', 0, 0, 0, 0, 'W', 'E', 'B', 'P', 'V', 'P', '8', ' '};
    q.texture(q.image(webp, "image/webp"), kNearestSampler);
    q.f.j["materials"] = {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}};
    const std::string e = render_error(q.f.write("materials_webp"));
    EXPECT_NE(e.find("image 0 is WebP"), std::string::npos) << e;
  }
  {
    TexturedQuad q;
    const std::vector<uint8_t> broken = {0x89, 'P', 'N', 'G', 1, 2, 3};
    q.texture(q.image(broken), kNearestSampler);
    q.f.j["materials"] = {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}};
    const std::string e = render_error(q.f.write("materials_broken_png"));
    EXPECT_NE(e.find("image 0 (PNG) does not decode"), std::string::npos) << e;
  }
  {
    // A 16-bit PNG decodes at 8 bits a channel, and says so once, on the
    // render that decodes it.
    TexturedQuad q;
    std::vector<uint16_t> texels(4 * 4 * 4);
    for (size_t i = 0; i < texels.size(); ++i) texels[i] = static_cast<uint16_t>(i % 4 == 3 ? 65535 : 1000 * i);
    q.texture(q.image(png16(4, 4, texels)), kNearestSampler);
    q.f.j["materials"] = {{{"pbrMetallicRoughness", {{"metallicRoughnessTexture", {{"index", 0}}}}}}};
    const rayfold::Scene scene = rayfold::Scene::load(q.f.write("materials_png16"));
    EXPECT_TRUE(scene.warnings().empty()) << testing::PrintToString(scene.warnings());
    rayfold::Renderer renderer(scene);
    const rayfold::GBuffer g = renderer.render(quad_camera(1.0, 4), rayfold::Fold::none, rayfold::kMetallicRoughness);
    ASSERT_EQ(g.warnings.size(), 1u) << testing::PrintToString(g.warnings);
    EXPECT_NE(g.warnings[0].find("image 0 is a 16-bit PNG: decoded at 8 bits"), std::string::npos) << g.warnings[0];
    // Pixel (x, y) sees texel (x, y): metallic is its blue, roughness its green, within 8 bits.
    for (int y = 0; y < 4; ++y)
      for (int x = 0; x < 4; ++x) {
        const size_t p = static_cast<size_t>(y) * 4 + x, t = 4 * p;
        EXPECT_NEAR(g.metallic_roughness[2 * p], texels[t + 2] / 65535.0, 1.0 / 255) << p;
        EXPECT_NEAR(g.metallic_roughness[2 * p + 1], texels[t + 1] / 65535.0, 1.0 / 255) << p;
      }
    EXPECT_TRUE(renderer.render(quad_camera(1.0, 4), rayfold::Fold::none, rayfold::kMetallicRoughness).warnings.empty())
        << "said once";
  }
  {
    TexturedQuad q(false);  // no TEXCOORD_0
    q.texture(q.image(png(pattern(4, 4, 1))), kNearestSampler);
    q.f.j["materials"] = {{{"name", "wood"}, {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", 0}}}}}}};
    const rayfold::Scene scene = rayfold::Scene::load(q.f.write("materials_no_texcoords"));
    rayfold::Renderer renderer(scene);
    const rayfold::GBuffer g = renderer.render(quad_camera(1.0, 8), rayfold::Fold::none, rayfold::kBaseColor);
    ASSERT_EQ(g.warnings.size(), 1u) << testing::PrintToString(g.warnings);
    EXPECT_NE(g.warnings[0].find("mesh 0 ('quad') lacks TEXCOORD_0"), std::string::npos) << g.warnings[0];
    EXPECT_NE(g.warnings[0].find("material 0 ('wood')"), std::string::npos) << g.warnings[0];
  }
}

TEST(Materials, EveryBackendAndFoldGivesTheReferencesBits) {
  // Seen at a slant in perspective, the quad's footprint changes across
  // it: trilinear lookups between levels, the same in every mode.
  TexturedQuad q;
  const int tex = q.texture(q.image(png(pattern(64, 64, 5))), {{"wrapS", 33648}});
  q.f.j["materials"] = {{{"pbrMetallicRoughness", {{"baseColorTexture", {{"index", tex}}}}},
                         {"emissiveTexture", {{"index", tex}}},
                         {"emissiveFactor", {1, 1, 1}}}};
  const rayfold::Scene scene = rayfold::Scene::load(q.f.write("materials_bits"));
  const rayfold::Camera camera = rayfold::Camera::look_at({0.4, -2.5, 1.2}, {0, 0.3, 0}, {0, 0, 1}, 60.0, 64, 48);
  const rayfold::GBuffer want =
      rayfold::testing::same_bits_on_every_backend_and_fold(scene, camera, kMaterialChannels | rayfold::kLabel);
  size_t hits = 0;
  for (size_t i = 0; i < want.label.size(); ++i) hits += want.label[i] != rayfold::kMiss;
  EXPECT_GT(hits, 400u);
}

}  // namespace
