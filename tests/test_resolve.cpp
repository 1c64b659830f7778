// The G-buffer's resolved channels (shading normal, texture coordinates,
// position, object position, material id) against a float64 resolve of the
// same glTF written here, against the ray, and against themselves across
// backends and fold modes.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>

#include "api/scene_state.h"
#include "gltf_fixture.h"
#include "rayfold/rayfold.h"
#include "resolve/resolve.h"
#include "test_util.h"

namespace {

using rayfold::core::testing::GltfFile;

// A bent quad (two triangles, z lifted at one corner) with unit normals
// leaning away from the face, two texture coordinate sets and materials 1
// and (none); placed twice: turned and scaled unevenly, and mirrored.
struct QuadFile {
  std::vector<glm::vec3> p = {{-1, -1, 0}, {1, -1, 0.25f}, {1, 1, 0}, {-1, 1, 0}};
  std::vector<glm::vec3> n;
  std::vector<float> t0 = {0, 0, 1, 0, 1, 1, 0, 1};
  std::vector<float> t1 = {0.5f, 0.25f, 0.75f, 0.125f, 0.3f, 0.9f, 0.1f, 0.6f};
  std::vector<uint16_t> idx = {0, 1, 2, 0, 2, 3};
  glm::dmat4 m0, m1;  // the instances' world_from_object
  std::string path;

  explicit QuadFile(const std::string& name, bool with_normals = true) {
    for (glm::vec3 v :
         {glm::vec3(0.2f, 0.1f, 1), glm::vec3(-0.3f, 0.2f, 1), glm::vec3(0.1f, -0.4f, 1), glm::vec3(0, 0.3f, 1)})
      n.push_back(glm::normalize(v));
    GltfFile f;
    const int pos = f.positions(p);
    const int nor = f.accessor(f.view(n.data(), n.size() * 12), 5126, "VEC3", 4);
    const int uv0 = f.accessor(f.view(t0.data(), t0.size() * 4), 5126, "VEC2", 4);
    const int uv1 = f.accessor(f.view(t1.data(), t1.size() * 4), 5126, "VEC2", 4);
    const int first = f.accessor(f.view(idx.data(), 6), 5123, "SCALAR", 3);
    const int second = f.accessor(f.view(idx.data() + 3, 6), 5123, "SCALAR", 3);
    nlohmann::json a = rayfold::core::testing::prim(pos, first), b = rayfold::core::testing::prim(pos, second);
    for (nlohmann::json* q : {&a, &b}) {
      if (with_normals) (*q)["attributes"]["NORMAL"] = nor;
      (*q)["attributes"]["TEXCOORD_0"] = uv0;
      (*q)["attributes"]["TEXCOORD_1"] = uv1;
    }
    a["material"] = 1;
    f.j["materials"] = {{{"name", "red"}}, {{"name", "green"}}};
    f.j["meshes"] = {{{"name", "quad"}, {"primitives", {a, b}}}};
    const double turn[4] = {0.2, 0.3, 0.1, 0.927};  // x, y, z, w, normalised by the loader
    f.j["nodes"] = {{{"mesh", 0},
                     {"translation", {-1.5, 0.2, -6}},
                     {"rotation", {turn[0], turn[1], turn[2], turn[3]}},
                     {"scale", {1.3, 0.8, 1.1}}},
                    {{"mesh", 0}, {"translation", {1.4, -0.1, -5}}, {"scale", {-1.0, 1.2, 1.0}}}};
    path = f.write(name);
    const glm::dquat q = glm::normalize(glm::dquat(turn[3], turn[0], turn[1], turn[2]));
    m0 = glm::translate(glm::dmat4(1.0), glm::dvec3(-1.5, 0.2, -6)) * glm::mat4_cast(q) *
         glm::scale(glm::dmat4(1.0), glm::dvec3(1.3, 0.8, 1.1));
    m1 = glm::translate(glm::dmat4(1.0), glm::dvec3(1.4, -0.1, -5)) *
         glm::scale(glm::dmat4(1.0), glm::dvec3(-1, 1.2, 1));
  }
};

constexpr unsigned kResolved = rayfold::kEveryChannel & ~static_cast<unsigned>(rayfold::kAllChannels);

// |got - want| within `ulps` of float's precision at want's scale (at least 1).
void expect_near(float got, double want, double ulps, const char* what, size_t pixel) {
  const double tolerance = ulps * 0x1p-24 * std::max(1.0, std::fabs(want));
  ASSERT_LE(std::fabs(got - want), tolerance) << what << " at pixel " << pixel << ": got " << got << ", want " << want;
}

TEST(Resolve, ChannelsEqualAFloat64ResolveOfTheFile) {
  const QuadFile quad("resolve_quad");
  const rayfold::Scene scene = rayfold::Scene::load(quad.path);
  // 24576 pixels: the resolve's runs of pixels on one triangle cross its
  // threads' chunks of 8192.
  const rayfold::Camera camera = rayfold::Camera::look_at({0, 0, 1}, {0, 0, -5.5}, {0, 1, 0}, 50.0, 192, 128);
  rayfold::Renderer renderer(scene);
  const rayfold::GBuffer g = renderer.render(camera, rayfold::Fold::none, kResolved | rayfold::kAllChannels);
  ASSERT_GT(g.hits, 2800u);
  size_t seen[2] = {0, 0};
  for (size_t i = 0; i < static_cast<size_t>(g.width) * g.height; ++i) {
    const uint32_t inst = g.instance_id[i];
    if (inst == rayfold::kMiss) {
      EXPECT_EQ(g.material_id[i], rayfold::kMiss);
      for (int k = 0; k < 3; ++k) ASSERT_EQ(g.position[3 * i + k], 0.0f) << i;
      continue;
    }
    ++seen[inst];
    const uint32_t tri = g.primitive_id[i];
    const uint16_t* v = quad.idx.data() + 3 * tri;
    const double u = g.uv[2 * i], w = g.uv[2 * i + 1], b0 = 1.0 - u - w;
    const glm::dmat4& m = inst == 0 ? quad.m0 : quad.m1;
    const glm::dvec3 o = b0 * glm::dvec3(quad.p[v[0]]) + u * glm::dvec3(quad.p[v[1]]) + w * glm::dvec3(quad.p[v[2]]);
    const glm::dvec3 world = glm::dvec3(m * glm::dvec4(o, 1.0));
    const glm::dvec3 ns =
        glm::normalize(glm::transpose(glm::inverse(glm::dmat3(m))) *
                       (b0 * glm::dvec3(quad.n[v[0]]) + u * glm::dvec3(quad.n[v[1]]) + w * glm::dvec3(quad.n[v[2]])));
    for (int k = 0; k < 3; ++k) {
      expect_near(g.object_position[3 * i + k], o[k], 2, "object_position", i);
      expect_near(g.position[3 * i + k], world[k], 2, "position", i);
      expect_near(g.shading_normal[3 * i + k], ns[k], 2, "shading_normal", i);
    }
    for (int k = 0; k < 2; ++k) {
      const double t0 = b0 * quad.t0[2 * v[0] + k] + u * quad.t0[2 * v[1] + k] + w * quad.t0[2 * v[2] + k];
      const double t1 = b0 * quad.t1[2 * v[0] + k] + u * quad.t1[2 * v[1] + k] + w * quad.t1[2 * v[2] + k];
      expect_near(g.texcoord[2 * i + k], t0, 2, "texcoord", i);
      expect_near(g.texcoord1[2 * i + k], t1, 2, "texcoord1", i);
    }
    EXPECT_EQ(g.material_id[i], tri == 0 ? 1u : rayfold::kDefaultMaterial) << i;
    // No COLOR_0, no texture, default factors: white, fully metallic and
    // rough, exactly (a mesh without COLOR_0 keeps no colours to interpolate).
    for (int k = 0; k < 4; ++k) ASSERT_EQ(g.base_color[4 * i + k], 1.0f) << "base_color at pixel " << i;
    ASSERT_EQ(g.metallic_roughness[2 * i], 1.0f) << i;
    ASSERT_EQ(g.metallic_roughness[2 * i + 1], 1.0f) << i;
    // The position is where the pixel's ray meets the surface: the depth
    // along the ray's unit direction from the eye.
    const size_t x = i % g.width, y = i / g.width;
    const rayfold::Vec3 d = camera.ray_direction(static_cast<int>(x), static_cast<int>(y));
    const glm::dvec3 along = glm::dvec3(0, 0, 1) + double(g.depth[i]) * glm::dvec3(d[0], d[1], d[2]);
    for (int k = 0; k < 3; ++k) ASSERT_NEAR(g.position[3 * i + k], along[k], 1e-5) << "position against the ray, " << i;
  }
  EXPECT_GT(seen[0], 1200u);
  EXPECT_GT(seen[1], 1200u);  // the mirrored instance: its normals through a negative determinant
}

TEST(Resolve, EveryBackendAndFoldGivesTheReferencesBits) {
  const QuadFile quad("resolve_bits");
  const rayfold::Scene scene = rayfold::Scene::load(quad.path);
  const rayfold::Camera camera = rayfold::Camera::look_at({0.1, 0, 1}, {0, 0, -5.5}, {0, 1, 0}, 50.0, 80, 60);
  rayfold::RendererOptions cpu;
  cpu.backend = rayfold::Backend::cpu;
  rayfold::Renderer reference(scene, cpu);
  const rayfold::GBuffer want = reference.render(camera, rayfold::Fold::none, kResolved);
  EXPECT_EQ(want.channels, kResolved);
  EXPECT_TRUE(want.depth.empty() && want.uv.empty() && want.instance_id.empty()) << "planes not asked for are empty";
  rayfold::Renderer opencl(scene);
  for (rayfold::Fold fold : {rayfold::Fold::none, rayfold::Fold::y, rayfold::Fold::x, rayfold::Fold::xy}) {
    for (rayfold::Renderer* r : {&reference, &opencl}) {
      const rayfold::GBuffer got = r->render(camera, fold, kResolved);
      const std::string what = std::string(r == &opencl ? "opencl" : "cpu") + " fold " + rayfold::fold_name(fold);
      EXPECT_EQ(rayfold::count_differing_pixels(got, want), 0u) << what;
    }
  }
  // Aligned views: each view's planes are its own render's.
  const std::vector<rayfold::GBuffer> views = opencl.render_views({camera, camera}, rayfold::Fold::xy, 0, kResolved);
  for (const rayfold::GBuffer& v : views) EXPECT_EQ(rayfold::count_differing_pixels(v, want), 0u);
}

TEST(Resolve, AMeshWithoutNormalsShadesFlatAndIsNamedOnce) {
  const QuadFile quad("resolve_flat", false);
  const rayfold::Scene scene = rayfold::Scene::load(quad.path);
  // Nothing is read before a render asks for it.
  for (const auto& mesh : scene.state()->scene.meshes) EXPECT_EQ(mesh.attributes.loaded, 0u);
  const rayfold::Camera camera = rayfold::Camera::look_at({0, 0, 1}, {0, 0, -5.5}, {0, 1, 0}, 50.0, 64, 48);
  rayfold::Renderer renderer(scene);
  const rayfold::GBuffer g = renderer.render(camera, rayfold::Fold::none, rayfold::kShadingNormal | rayfold::kNormal);
  ASSERT_GT(g.hits, 100u);
  EXPECT_EQ(g.shading_normal, g.normal) << "flat shading is the geometric normal, bit for bit";
  size_t named = 0;
  for (const std::string& w : g.warnings) named += w.find("mesh 0 ('quad') has no NORMAL") != std::string::npos;
  EXPECT_EQ(named, 1u) << testing::PrintToString(g.warnings);
  const rayfold::GBuffer again = renderer.render(camera, rayfold::Fold::none, rayfold::kShadingNormal);
  EXPECT_TRUE(again.warnings.empty()) << "named once: " << testing::PrintToString(again.warnings);
  EXPECT_EQ(again.shading_normal, g.normal);
  // A mesh built in memory has positions only.
  rayfold::Scene made;
  const uint32_t mesh = made.add_mesh(std::vector<float>{-1, -1, -4, 1, -1, -4, 0, 1, -4}, {0, 1, 2});
  made.add_instance(mesh, rayfold::kIdentity);
  rayfold::Renderer r(made);
  const rayfold::GBuffer t = r.render(camera, rayfold::Fold::none, rayfold::kTexcoord | rayfold::kInstanceId);
  ASSERT_GT(t.hits, 10u);
  for (size_t i = 0; i < t.texcoord.size(); ++i) ASSERT_EQ(t.texcoord[i], 0.0f);
  ASSERT_FALSE(t.warnings.empty());
  EXPECT_NE(t.warnings[0].find("has no TEXCOORD_0"), std::string::npos) << t.warnings[0];
}

// Each kind of stand-in once for all the meshes it applies to, the first
// three named: the sports car's 1,075 meshes said 2,150 lines.
TEST(Resolve, MeshesWithoutAnAttributeAreOneWarningAKind) {
  rayfold::Scene made;
  for (int m = 0; m < 5; ++m) {
    const float z = -4.0f - static_cast<float>(m);
    const uint32_t mesh =
        made.add_mesh(std::vector<float>{-1, -1, z, 1, -1, z, 0, 1, z}, {0, 1, 2}, "m" + std::to_string(m));
    made.add_instance(mesh, rayfold::kIdentity);
  }
  const rayfold::Camera camera = rayfold::Camera::look_at({0, 0, 1}, {0, 0, -5.5}, {0, 1, 0}, 50.0, 64, 48);
  rayfold::Renderer r(made);
  const rayfold::GBuffer g = r.render(camera, rayfold::Fold::none, rayfold::kTexcoord | rayfold::kShadingNormal);
  ASSERT_EQ(g.warnings.size(), 2u) << testing::PrintToString(g.warnings);
  EXPECT_EQ(g.warnings[0].rfind("5 meshes (mesh 0 ('m0'), mesh 1 ('m1'), mesh 2 ('m2'), ...) have no NORMAL: ", 0), 0u)
      << g.warnings[0];
  EXPECT_EQ(g.warnings[1].rfind("5 meshes (mesh 0 ('m0'), mesh 1 ('m1'), mesh 2 ('m2'), ...) have no TEXCOORD_0: ", 0),
            0u)
      << g.warnings[1];
}

TEST(Resolve, ChannelNamesAndTheExrRoundTrip) {
  EXPECT_EQ(rayfold::parse_channels("shading_normal, texcoord,P,Pref,MaterialID"),
            rayfold::kShadingNormal | rayfold::kTexcoord | rayfold::kPosition | rayfold::kObjectPosition |
                rayfold::kMaterialId);
  EXPECT_EQ(rayfold::parse_channels("uv"), rayfold::parse_channels("barycentrics"));
  try {
    rayfold::parse_channels("albedo");
    FAIL() << "an unknown channel was taken";
  } catch (const rayfold::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("unknown channel 'albedo'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("shading_normal"), std::string::npos) << e.what();
  }
  const QuadFile quad("resolve_exr");
  const rayfold::Scene scene = rayfold::Scene::load(quad.path);
  const rayfold::Camera camera = rayfold::Camera::look_at({0, 0, 1}, {0, 0, -5.5}, {0, 1, 0}, 50.0, 40, 30);
  rayfold::Renderer renderer(scene);
  const rayfold::GBuffer g = renderer.render(camera, rayfold::Fold::none, rayfold::kEveryChannel);
  const std::string path = (rayfold::core::testing::temp_dir() / "resolve.exr").string();
  rayfold::write_exr(path, g, camera, scene);
  const rayfold::GBuffer back = rayfold::read_exr(path);
  EXPECT_EQ(back.channels, rayfold::kEveryChannel);
  EXPECT_EQ(back.depth, g.depth);
  EXPECT_EQ(back.normal, g.normal);
  EXPECT_EQ(back.uv, g.uv);
  EXPECT_EQ(back.instance_id, g.instance_id);
  EXPECT_EQ(back.shading_normal, g.shading_normal);
  EXPECT_EQ(back.texcoord, g.texcoord);
  EXPECT_EQ(back.texcoord1, g.texcoord1);
  EXPECT_EQ(back.position, g.position);
  EXPECT_EQ(back.object_position, g.object_position);
  EXPECT_EQ(back.material_id, g.material_id);
  EXPECT_EQ(back.hits, g.hits);
  EXPECT_EQ(rayfold::count_differing_pixels(back, g), 0u);
  // The header gives the camera back (its rays, to double precision), the
  // depth's kind and the names; also for orthographic and planar views.
  auto same_rays = [](const rayfold::Camera& a, const rayfold::Camera& b) {
    ASSERT_EQ(a.width(), b.width());
    for (int y = 0; y < a.height(); y += 7)
      for (int x = 0; x < a.width(); x += 5)
        for (int k = 0; k < 3; ++k) {
          ASSERT_NEAR(a.ray_direction(x, y)[k], b.ray_direction(x, y)[k], 1e-12) << x << ", " << y;
          ASSERT_NEAR(a.ray_origin(x, y)[k], b.ray_origin(x, y)[k], 1e-12) << x << ", " << y;
        }
  };
  const rayfold::ExrHeader h = rayfold::read_exr_header(path);
  EXPECT_EQ(h.instance_names, scene.instance_names());
  EXPECT_EQ(h.depth_kind, rayfold::Depth::distance);
  EXPECT_EQ(h.fold, "none");
  ASSERT_TRUE(h.camera.has_value());
  same_rays(*h.camera, camera);
  rayfold::RendererOptions planar;
  planar.depth = rayfold::Depth::planar;
  rayfold::Renderer flat(scene, planar);
  const rayfold::Camera ortho = rayfold::Camera::orthographic({0.2, 0.1, 1}, {0, 0, -5.5}, {0, 1, 0}, 3.0, 40, 30);
  rayfold::write_exr(path, flat.render(ortho, rayfold::Fold::xy, rayfold::kDepth), ortho, scene);
  const rayfold::ExrHeader o = rayfold::read_exr_header(path);
  EXPECT_EQ(o.depth_kind, rayfold::Depth::planar);
  ASSERT_TRUE(o.camera.has_value() && o.camera->is_orthographic());
  same_rays(*o.camera, ortho);
}

// The shading normal's divisions run in one pass over each chunk of
// pixels, in vector lanes (4 doubles where the machine has AVX2): each pixel
// must still get the bits of the documented rule worked out alone, the
// corners' normals through the inverse transpose, interpolated
// b0 * n0 + u * n1 + v * n2, divided by the length; the geometric normal
// where the sum has no length (zero, or not finite: a NaN normal) or the
// mesh no normals; 0 on a miss. Three chunks of the resolve's 8,192 pixels,
// the last one short: one of runs of 1 to 9 pixels of every kind, one of
// misses and flat triangles alone (nothing to divide), one mixed again.
TEST(Resolve, ShadingNormalsInVectorLanesGiveALonePixelsBits) {
  using namespace rayfold::core;
  Scene scene;
  scene.meshes.resize(3);
  Mesh& mesh = scene.meshes[0];
  mesh.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0.5f}};
  mesh.indices = {0, 1, 2, 1, 3, 2};
  // Vertex 1's normal is vertex 0's turned around: halfway between them on
  // the first triangle's edge the sum is zero, and the geometric normal stands in.
  mesh.attributes.normals = {glm::normalize(glm::vec3(0.3f, -0.2f, 1)), -glm::normalize(glm::vec3(0.3f, -0.2f, 1)),
                             glm::normalize(glm::vec3(-0.1f, 0.4f, 1)), glm::normalize(glm::vec3(0.2f, 0.2f, 0.9f))};
  mesh.attributes.loaded = mesh.attributes.present = kAttributeNormal;
  // A mesh without normals (flat: the geometric normal), and one whose
  // second vertex's normal is NaN (a sum that is not finite).
  Mesh& flat = scene.meshes[1];
  flat.positions = {{0, 0, 1}, {1, 0, 1}, {0, 1, 1}};
  flat.indices = {0, 1, 2};
  Mesh& broken = scene.meshes[2];
  broken.positions = flat.positions;
  broken.indices = flat.indices;
  broken.attributes.normals = {{0, 0, 1}, {NAN, 0, 1}, {0, 1, 0}};
  broken.attributes.loaded = broken.attributes.present = kAttributeNormal;
  scene.instances.resize(3);
  scene.instances[1].mesh = 1;
  scene.instances[2].mesh = 2;
  Instance& inst = scene.instances[0];
  inst.world_from_object = glm::translate(glm::dmat4(1.0), glm::dvec3(0.5, -2, 3)) *
                           glm::rotate(glm::dmat4(1.0), 0.7, glm::dvec3(0.3, 1, 0.2)) *
                           glm::scale(glm::dmat4(1.0), glm::dvec3(1.7, -0.6, 2.3));
  constexpr size_t kChunk = 8192;  // resolve.cpp's
  std::vector<uint32_t> instance, primitive;
  std::vector<float> bary, geometric;
  rayfold::core::testing::Rng rng(49);
  // A run of `length` pixels on instance id's triangle tri (id RF_INVALID: a miss).
  auto add_run = [&](uint32_t id, uint32_t tri, size_t length) {
    for (size_t k = 0; k < length; ++k) {
      float u = rng.uniformf(0.0f, 1.0f), v = rng.uniformf(0.0f, 1.0f);
      if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
      if (id == 0 && tri == 0 && k == 0) u = 0.5f, v = 0.0f;  // the zero sum
      instance.push_back(id);
      primitive.push_back(id == 0 ? tri : 0);
      bary.insert(bary.end(), {u, v});
      if (id == RF_INVALID)
        geometric.insert(geometric.end(), {0.0f, 0.0f, 0.0f});
      else
        geometric.insert(geometric.end(), {0.25f * tri, 0.5f, -0.75f - 0.125f * id});
    }
  };
  auto mixed = [&](size_t until) {
    for (uint32_t run = 0; instance.size() < until; ++run) {
      const uint32_t id = run % 5 == 3 ? RF_INVALID : run % 7 == 2 ? 1u : run % 11 == 6 ? 2u : 0u;
      add_run(id, run % 2, std::min<size_t>(1 + run % 9, until - instance.size()));
    }
  };
  mixed(kChunk);
  for (uint32_t run = 0; instance.size() < 2 * kChunk; ++run)
    add_run(run % 2 ? 1u : RF_INVALID, 0, std::min<size_t>(7, 2 * kChunk - instance.size()));
  mixed(2 * kChunk + 3001);
  const size_t pixels = instance.size();
  HitPlanes in;
  in.pixels = pixels;
  in.instance = instance.data();
  in.primitive = primitive.data();
  in.barycentrics = bary.data();
  in.normal = geometric.data();
  std::vector<float> got(3 * pixels, -1.0f);
  ResolvedPlanes out;
  out.shading_normal = got.data();
  resolve(scene, in, RayCone{}, out, 2);

  size_t kinds[5] = {0, 0, 0, 0, 0};  // interpolated, zero sum, not finite, flat, miss
  for (size_t p = 0; p < pixels; ++p) {
    float want[3] = {0.0f, 0.0f, 0.0f};
    size_t kind = 4;
    if (instance[p] == 1) {
      std::copy(&geometric[3 * p], &geometric[3 * p + 3], want);
      kind = 3;
    } else if (instance[p] != RF_INVALID) {
      const Mesh& m = scene.meshes[instance[p]];
      const glm::dmat3 normal_from_object =
          glm::transpose(glm::inverse(glm::dmat3(scene.instances[instance[p]].world_from_object)));
      glm::dvec3 n[3];
      for (int k = 0; k < 3; ++k)
        n[k] = normal_from_object * glm::dvec3(m.attributes.normals[m.indices[3 * primitive[p] + k]]);
      const double u = bary[2 * p], v = bary[2 * p + 1], b0 = (1.0 - u) - v;
      const glm::dvec3 sum = b0 * n[0] + u * n[1] + v * n[2];
      const double length = std::sqrt(sum.x * sum.x + sum.y * sum.y + sum.z * sum.z);
      const bool unit = length > 0.0 && std::isfinite(length);
      for (int c = 0; c < 3; ++c) want[c] = unit ? static_cast<float>(sum[c] / length) : geometric[3 * p + c];
      kind = unit ? 0 : length == 0.0 ? 1 : 2;
    }
    kinds[kind]++;
    ASSERT_EQ(std::memcmp(want, &got[3 * p], sizeof want), 0)
        << "pixel " << p << " (instance " << instance[p] << ", triangle " << primitive[p] << ", kind " << kind
        << "): got (" << got[3 * p] << ", " << got[3 * p + 1] << ", " << got[3 * p + 2] << "), want (" << want[0]
        << ", " << want[1] << ", " << want[2] << ")";
  }
  for (size_t k = 0; k < 5; ++k) EXPECT_GT(kinds[k], 0u) << "no pixel of kind " << k << ": that case went untested";
}

}  // namespace
