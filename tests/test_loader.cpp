// The glTF loader: round trips of generated files, hand-built files that use
// strips, fans, every index type, strides, matrices and TRS, clear errors on
// broken files, and every real scene in ../shared/scenes when present.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include "fixtures/gltf_writer.h"
#include "fixtures/scene_gen.h"
#include "gltf_fixture.h"
#include "pipeline/pipeline.h"
#include "scene/gltf/loader.h"
#include "scene/gltf_loader.h"
#include "test_util.h"
#include "util/errors.h"

namespace rayfold::core {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::expect_error;
using testing::GltfFile;
using testing::mesh;
using testing::node_with_mesh;
using testing::prim;
using testing::temp_dir;

TEST(Loader, GeneratedSceneRoundTrips) {
  GenOptions gen;
  gen.objects = 60;
  gen.triangle_budget = 30000;
  const Scene a = generate_atrium(gen);
  const std::string path = (temp_dir() / "roundtrip.glb").string();
  write_glb(a, path);
  const Scene b = load_gltf(path);
  ASSERT_EQ(a.meshes.size(), b.meshes.size());
  ASSERT_EQ(a.instances.size(), b.instances.size());
  for (size_t m = 0; m < a.meshes.size(); ++m) {
    EXPECT_EQ(a.meshes[m].indices, b.meshes[m].indices);
    ASSERT_EQ(a.meshes[m].positions.size(), b.meshes[m].positions.size());
    EXPECT_EQ(0, std::memcmp(a.meshes[m].positions.data(), b.meshes[m].positions.data(),
                             a.meshes[m].positions.size() * sizeof(glm::vec3)));
  }
  for (size_t i = 0; i < a.instances.size(); ++i) {
    EXPECT_EQ(a.instances[i].mesh, b.instances[i].mesh);
    EXPECT_TRUE(a.instances[i].world_from_object == b.instances[i].world_from_object) << "instance " << i;
  }
  ASSERT_TRUE(b.camera.has_value());
  EXPECT_NEAR(glm::length(a.camera->eye - b.camera->eye), 0.0, 1e-9);
  EXPECT_NEAR(b.camera->vfov_degrees, a.camera->vfov_degrees, 1e-9);
  const glm::dvec3 da = glm::normalize(a.camera->look_at - a.camera->eye);
  const glm::dvec3 db = glm::normalize(b.camera->look_at - b.camera->eye);
  EXPECT_NEAR(glm::length(da - db), 0.0, 1e-9);
}

// A file whose JSON is large enough for tinygltf's parse to run beside the
// checks' (gltf/document.cpp) reads as on one thread: the same scene.
TEST(Loader, LargeJsonReadsSideBySideAsOnOneThread) {
  GltfFile f;
  f.one_triangle();
  f.j["nodes"].push_back({{"mesh", 0}, {"translation", {1.0, 2.0, 3.0}}});
  f.j["scenes"] = {{{"nodes", {0, 1}}}};
  f.j["extras"] = {{"padding", std::string(size_t{600} << 10, ' ')}};
  const std::string path = f.write("large_json");
  LoadOptions one, two;
  one.threads = 1;
  two.threads = 2;
  const size_t reads = gltf::Loader::side_by_side_reads();
  const Scene a = load_gltf(path, nullptr, one);
  EXPECT_EQ(gltf::Loader::side_by_side_reads(), reads) << "one thread read it side by side";
  const Scene b = load_gltf(path, nullptr, two);
  EXPECT_EQ(gltf::Loader::side_by_side_reads(), reads + 1) << "two threads did not read it side by side";
  ASSERT_EQ(a.meshes.size(), 1u);
  ASSERT_EQ(b.meshes.size(), 1u);
  EXPECT_EQ(a.meshes[0].indices, b.meshes[0].indices);
  EXPECT_EQ(a.meshes[0].positions, b.meshes[0].positions);
  ASSERT_EQ(a.instances.size(), 2u);
  ASSERT_EQ(b.instances.size(), 2u);
  for (size_t i = 0; i < 2; ++i) EXPECT_TRUE(a.instances[i].world_from_object == b.instances[i].world_from_object);
}

TEST(Loader, IndexTypesStridesStripsFansAndTransforms) {
  GltfFile f;
  // Four vertices of a unit quad, interleaved with 12 bytes of padding (a
  // stride of 24, as a normal attribute would leave).
  const float inter[] = {0, 0, 0, 9, 9, 9, 1, 0, 0, 9, 9, 9, 1, 1, 0, 9, 9, 9, 0, 1, 0, 9, 9, 9};
  const int strided = f.accessor(f.view(inter, sizeof inter, 24), 5126, "VEC3", 4);
  f.j["accessors"][strided]["min"] = {0, 0, 0};
  f.j["accessors"][strided]["max"] = {1, 1, 0};
  const uint8_t i8[] = {0, 1, 2, 0, 2, 3};
  const uint16_t i16[] = {0, 1, 2, 0, 2, 3};
  const uint32_t i32[] = {0, 1, 2, 0, 2, 3};
  const int a8 = f.accessor(f.view(i8, sizeof i8), 5121, "SCALAR", 6);
  const int a16 = f.accessor(f.view(i16, sizeof i16), 5123, "SCALAR", 6);
  const int a32 = f.accessor(f.view(i32, sizeof i32), 5125, "SCALAR", 6);
  // A strip and a fan over 5 vertices: 3 triangles each.
  const int strip_pos = f.positions({{0, 0, 0}, {0, 1, 0}, {1, 0, 0}, {1, 1, 0}, {2, 0, 0}});
  const int fan_pos = f.positions({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {-1, 1, 0}});
  const int points_pos = f.positions({{0, 0, 0}});
  f.j["meshes"] = json::array({mesh({prim(strided, a8)}), mesh({prim(strided, a16)}), mesh({prim(strided, a32)}),
                               mesh({prim(strided)}),  // non-indexed: 1 triangle of 4 vertices
                               mesh({prim(strip_pos, -1, 5), prim(fan_pos, -1, 6), prim(points_pos, -1, 0)}),
                               // Two lists of triangles: the first taken whole, the second after it.
                               mesh({prim(strided, a16), prim(strided, a32)})});
  json n0, n1, n2, n3, n4, n5;
  n0["mesh"] = 0;
  n0["children"] = {1};
  n0["translation"] = {10, 0, 0};
  n1["mesh"] = 1;
  n1["matrix"] = {2, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 5, 0, 1};
  n2["mesh"] = 2;
  n2["rotation"] = {0, 0, 0.7071067811865476, 0.7071067811865476};
  n2["scale"] = {1, 2, 3};
  n3["mesh"] = 3;
  n4["mesh"] = 4;
  n5["mesh"] = 5;
  f.j["nodes"] = json::array({n0, n1, n2, n3, n4, n5});
  f.j["scenes"] = json::array({json{{"nodes", {0, 2, 3, 4, 5}}}});
  f.j["scene"] = 0;
  std::vector<std::string> warnings;
  const Scene s = load_gltf(f.write("kinds"), &warnings);
  ASSERT_EQ(s.meshes.size(), 6u);
  ASSERT_EQ(s.instances.size(), 6u);
  const std::vector<uint32_t> quad = {0, 1, 2, 0, 2, 3};
  for (int m = 0; m < 3; ++m) {
    EXPECT_EQ(s.meshes[m].indices, quad) << m;
    EXPECT_EQ(s.meshes[m].positions[2], glm::vec3(1, 1, 0)) << "stride skipped the padding";
  }
  EXPECT_EQ(s.meshes[3].indices, (std::vector<uint32_t>{0, 1, 2}));
  // Strip (spec order i, i+1+i%2, i+2-i%2) then fan (i+1, i+2, 0), offset by 5.
  EXPECT_EQ(s.meshes[4].indices, (std::vector<uint32_t>{0, 1, 2, 1, 3, 2, 2, 3, 4, 6, 7, 5, 7, 8, 5, 8, 9, 5}));
  EXPECT_EQ(s.meshes[5].indices, (std::vector<uint32_t>{0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7}));
  ASSERT_EQ(s.meshes[5].positions.size(), 8u);
  EXPECT_EQ(s.meshes[5].positions[6], glm::vec3(1, 1, 0));
  bool warned_points = false;
  for (const std::string& w : warnings) warned_points |= w.find("points or lines") != std::string::npos;
  EXPECT_TRUE(warned_points);
  // Depth-first order: node 0, its child 1, then 2, 3, 4.
  const glm::dvec3 p1 = transform_point(s.instances[1].world_from_object, glm::dvec3(1, 1, 0));
  EXPECT_NEAR(p1.x, 12.0, 1e-12);  // child: parent translation 10 + matrix scale 2 * 1
  EXPECT_NEAR(p1.y, 6.0, 1e-12);   // matrix translation 5 + 1
  const glm::dvec3 p2 = transform_point(s.instances[2].world_from_object, glm::dvec3(1, 0, 0));
  EXPECT_NEAR(p2.x, 0.0, 1e-9);  // 90 degrees about z takes +x to +y
  EXPECT_NEAR(p2.y, 1.0, 1e-9);
}

TEST(Loader, AnAttributeNoPrimitiveHasIsKeptAsNone) {
  // Mesh 0: one primitive with COLOR_0 and one without (the second's
  // vertices white); mesh 1: none has NORMAL, TEXCOORD_0 or COLOR_0.
  GltfFile f;
  const int pos = f.positions({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
  const std::vector<glm::vec4> red(3, glm::vec4(1, 0, 0, 1));
  const int colour = f.accessor(f.view(red.data(), red.size() * 16), 5126, "VEC4", 3);
  json coloured = prim(pos);
  coloured["attributes"]["COLOR_0"] = colour;
  f.j["meshes"] = json::array({mesh({coloured, prim(pos)}), mesh({prim(pos)})});
  f.j["nodes"] = json::array({node_with_mesh(0), node_with_mesh(1)});
  f.j["scenes"] = json::array({json{{"nodes", {0, 1}}}});
  LoadOptions o;
  o.attributes = kAttributeNormal | kAttributeTexcoord0 | kAttributeTexcoord1 | kAttributeColor0;
  const Scene s = load_gltf(f.write("absent_attributes"), nullptr, o);
  ASSERT_EQ(s.meshes.size(), 2u);
  const MeshAttributes& some = s.meshes[0].attributes;
  ASSERT_EQ(some.colors.size(), 6u);
  EXPECT_EQ(some.colors[0], glm::vec4(1, 0, 0, 1));
  EXPECT_EQ(some.colors[5], glm::vec4(1.0f)) << "a primitive without COLOR_0 among others: white per vertex";
  const MeshAttributes& none = s.meshes[1].attributes;
  EXPECT_TRUE(none.colors.empty()) << none.colors.size();
  EXPECT_TRUE(none.normals.empty()) << none.normals.size();
  EXPECT_TRUE(none.texcoords[0].empty()) << none.texcoords[0].size();
  EXPECT_TRUE(none.texcoords[1].empty()) << none.texcoords[1].size();
  EXPECT_EQ(none.missing & kAttributeColor0, kAttributeColor0) << "still named as missing for the warnings";
}

TEST(Loader, ListsOfTrianglesDropAPartialLastTriangleWithAWarning) {
  // 7 indices: two triangles, and one index that makes none, ignored and said.
  GltfFile f;
  f.one_triangle({0, 1, 2, 2, 1, 0, 1});
  std::vector<std::string> warnings;
  const Scene s = load_gltf(f.write("partial"), &warnings);
  ASSERT_EQ(s.meshes.size(), 1u);
  EXPECT_EQ(s.meshes[0].indices, (std::vector<uint32_t>{0, 1, 2, 2, 1, 0}));
  bool warned = false;
  for (const std::string& w : warnings)
    warned |= w.find("7 triangle vertices, not a multiple of 3; the last 1") != std::string::npos;
  EXPECT_TRUE(warned);
}

TEST(Loader, BrokenFilesGiveClearErrors) {
  const fs::path dir = temp_dir();
  expect_error((dir / "missing.glb").string(), "cannot open");
  {
    std::ofstream((dir / "empty.gltf").string());
    expect_error((dir / "empty.gltf").string(), "empty");
  }
  {
    std::ofstream(dir / "bad.gltf") << "{ this is not json";
    expect_error((dir / "bad.gltf").string(), "");
  }
  {
    GenOptions gen;
    gen.objects = 5;
    gen.triangle_budget = 2000;
    const std::string good = (dir / "good.glb").string();
    write_glb(generate_atrium(gen), good);
    std::ifstream in(good, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    std::ofstream(dir / "truncated.glb", std::ios::binary).write(bytes.data(), bytes.size() / 2);
    expect_error((dir / "truncated.glb").string(), "");
  }
  {
    GltfFile f;
    f.one_triangle({0, 1, 7});
    f.j["nodes"] = json::array({node_with_mesh(0)});
    expect_error(f.write("index_range"), "past the 3 vertices");
  }
  {
    GltfFile f;
    f.one_triangle();
    json a = node_with_mesh(0), b;
    a["children"] = {1};
    b["children"] = {0};
    f.j["nodes"] = json::array({a, b});
    f.j["scenes"] = json::array({json{{"nodes", {0}}}});
    expect_error(f.write("cycle"), "cycle");
  }
  {
    GltfFile f;
    f.one_triangle();
    f.j["nodes"] = json::array({node_with_mesh(0)});
    f.j["extensionsUsed"] = {"EXT_geometry_of_the_future"};
    f.j["extensionsRequired"] = {"EXT_geometry_of_the_future"};
    expect_error(f.write("unknown_required"), "EXT_geometry_of_the_future");
  }
  {
    GltfFile f;
    f.one_triangle();
    f.j["accessors"][0]["count"] = 1000;
    f.j["nodes"] = json::array({node_with_mesh(0)});
    expect_error(f.write("past_view"), "");
  }
  {
    GltfFile f;
    const std::vector<glm::vec3> p = {{0, 0, 0}, {NAN, 0, 0}, {0, 1, 0}};
    const int a = f.accessor(f.view(p.data(), 36), 5126, "VEC3", 3);
    f.j["accessors"][a]["min"] = {0, 0, 0};
    f.j["accessors"][a]["max"] = {1, 1, 0};
    f.j["meshes"] = json::array({mesh({prim(a)})});
    f.j["nodes"] = json::array({node_with_mesh(0)});
    expect_error(f.write("nan"), "not finite");
  }
  {
    GltfFile f;
    f.one_triangle();
    f.j["nodes"] = json::array({node_with_mesh(3)});
    expect_error(f.write("mesh_ref"), "mesh 3");
  }
}

// The real scenes, with the triangle and mesh counts their README gives.
TEST(Loader, SharedScenes) {
  const std::string dir = testing::shared_scenes_dir();
  if (dir.empty()) GTEST_SKIP() << "../shared/scenes not found (set RAYFOLD_SCENES_DIR); real scenes not tested";
  const std::map<std::string, std::pair<size_t, size_t>> expected = {
      {"conference.glb", {331179, 41}},     {"lost_empire.glb", {224998, 45}},    {"sports_car.glb", {300603, 1075}},
      {"dabrovic_sponza.glb", {66447, 33}}, {"stanford_dragon.glb", {871414, 1}}, {"armadillo.glb", {345944, 1}},
  };
  int found = 0;
  for (const auto& [name, counts] : expected) {
    const fs::path p = fs::path(dir) / name;
    if (!fs::exists(p)) {
      std::printf("note: %s absent; skipped\n", p.c_str());
      continue;
    }
    ++found;
    const Scene s = load_gltf(p.string());
    EXPECT_EQ(s.unique_triangle_count(), counts.first) << name;
    EXPECT_EQ(s.meshes.size(), counts.second) << name;
    EXPECT_FALSE(s.world_bounds().empty()) << name;
  }
  EXPECT_GT(found, 0);
}

// The same geometry written another way must load as the same positions:
// quantized, sparse, or displaced by morph targets at their default weights.
std::vector<glm::vec3> loaded_positions(const std::string& path) {
  const Scene scene = load_gltf(path);
  EXPECT_EQ(scene.meshes.size(), 1u);
  return scene.meshes.empty() ? std::vector<glm::vec3>{} : scene.meshes[0].positions;
}

TEST(Loader, QuantizedPositionsAsGltfReadsThem) {
  // KHR_mesh_quantization: integers as they are, normalized ones mapped to
  // [-1, 1] (bytes, shorts) or [0, 1] (unsigned).
  testing::GltfFile f;
  const int16_t s[9] = {0, 0, 0, 3, 0, 0, 0, -2, 5};
  const int pv = f.view(s, sizeof s);
  const int pa = f.accessor(pv, 5122, "VEC3", 3);
  const uint16_t idx[3] = {0, 1, 2};
  const int ia = f.accessor(f.view(idx, sizeof idx), 5123, "SCALAR", 3);
  f.j["meshes"] = {testing::mesh({testing::prim(pa, ia)})};
  f.j["nodes"] = {testing::node_with_mesh(0)};
  f.j["extensionsUsed"] = {"KHR_mesh_quantization"};
  f.j["extensionsRequired"] = {"KHR_mesh_quantization"};
  EXPECT_EQ(loaded_positions(f.write("quantized_shorts")), (std::vector<glm::vec3>{{0, 0, 0}, {3, 0, 0}, {0, -2, 5}}));
  f.j["accessors"][pa]["normalized"] = true;
  const std::vector<glm::vec3> n = loaded_positions(f.write("quantized_normalized"));
  ASSERT_EQ(n.size(), 3u);
  EXPECT_EQ(n[1].x, static_cast<float>(3.0 / 32767.0));
  EXPECT_EQ(n[2].y, static_cast<float>(-2.0 / 32767.0));
  const uint8_t b[12] = {0, 0, 0, 0, 255, 0, 0, 0, 0, 0, 128, 0};  // 4-byte aligned elements, stride 4
  testing::GltfFile g;
  const int bv = g.view(b, sizeof b, 4);
  const int ba = g.accessor(bv, 5121, "VEC3", 3);
  g.j["accessors"][ba]["normalized"] = true;
  const int gi = g.accessor(g.view(idx, sizeof idx), 5123, "SCALAR", 3);
  g.j["meshes"] = {testing::mesh({testing::prim(ba, gi)})};
  g.j["nodes"] = {testing::node_with_mesh(0)};
  g.j["extensionsUsed"] = {"KHR_mesh_quantization"};
  EXPECT_EQ(loaded_positions(g.write("quantized_ubytes")),
            (std::vector<glm::vec3>{{0, 0, 0}, {1, 0, 0}, {0, 0, static_cast<float>(128.0 / 255.0)}}));
}

TEST(Loader, SparseAccessorsEqualTheirDenseForm) {
  // Positions: a base of four and two substitutions; indices: a base of
  // zeros and three substitutions (tinygltf insists that index accessors
  // have a buffer view, so the zeros are written). Written densely, the same
  // triangles.
  const std::vector<glm::vec3> dense = {{0, 0, 0}, {4, 0, 0}, {0, 1, 0}, {7, 7, 7}};
  testing::GltfFile f;
  const int base = f.positions({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 0}});
  const uint16_t at[2] = {1, 3};
  const glm::vec3 values[2] = {{4, 0, 0}, {7, 7, 7}};
  const int at_view = f.view(at, sizeof at), values_view = f.view(values, sizeof values);
  f.j["accessors"][base]["sparse"] = {{"count", 2},
                                      {"indices", {{"bufferView", at_view}, {"componentType", 5123}}},
                                      {"values", {{"bufferView", values_view}}}};
  const uint32_t idx_at[3] = {0, 1, 2}, idx_values[3] = {3, 1, 0}, zeros[3] = {0, 0, 0};
  const int ia = f.accessor(f.view(zeros, sizeof zeros), 5125, "SCALAR", 3);
  f.j["accessors"][ia]["sparse"] = {
      {"count", 3},
      {"indices", {{"bufferView", f.view(idx_at, sizeof idx_at)}, {"componentType", 5125}}},
      {"values", {{"bufferView", f.view(idx_values, sizeof idx_values)}}}};
  f.j["meshes"] = {testing::mesh({testing::prim(base, ia)})};
  f.j["nodes"] = {testing::node_with_mesh(0)};
  const Scene scene = load_gltf(f.write("sparse"));
  ASSERT_EQ(scene.meshes.size(), 1u);
  EXPECT_EQ(scene.meshes[0].positions, dense);
  EXPECT_EQ(scene.meshes[0].indices, (std::vector<uint32_t>{3, 1, 0}));
}

TEST(Loader, MorphTargetsAtTheirDefaultWeights) {
  // Mesh weights (0.5, 0.25) over two targets; a second node overrides them
  // with (1, 0) and gets a mesh of its own; a node with no weights uses the
  // mesh's. Displacements chosen so that the sums are exact.
  testing::GltfFile f;
  f.one_triangle();
  const int t0 = f.positions({{2, 0, 0}, {2, 0, 0}, {2, 0, 0}});
  const int t1 = f.positions({{0, 4, 0}, {0, 0, 0}, {0, 0, 8}});
  f.j["meshes"][0]["primitives"][0]["targets"] = {{{"POSITION", t0}}, {{"POSITION", t1}}};
  f.j["meshes"][0]["weights"] = {0.5, 0.25};
  f.j["nodes"].push_back({{"mesh", 0}, {"weights", {1.0, 0.0}}});
  f.j["nodes"].push_back({{"mesh", 0}});
  f.j["scenes"] = {{{"nodes", {0, 1, 2}}}};
  const Scene scene = load_gltf(f.write("morph"));
  ASSERT_EQ(scene.instances.size(), 3u);
  ASSERT_EQ(scene.meshes.size(), 2u);
  EXPECT_EQ(scene.instances[0].mesh, scene.instances[2].mesh);
  EXPECT_EQ(scene.meshes[scene.instances[0].mesh].positions, (std::vector<glm::vec3>{{1, 1, 0}, {2, 0, 0}, {1, 1, 2}}));
  EXPECT_EQ(scene.meshes[scene.instances[1].mesh].positions, (std::vector<glm::vec3>{{2, 0, 0}, {3, 0, 0}, {2, 1, 0}}));
  // A target moving texture coordinates: named when they are read, once.
  const std::vector<glm::vec2> uv = {{0, 0}, {1, 0}, {0, 1}};
  const int moved_uv = f.accessor(f.view(uv.data(), uv.size() * 8), 5126, "VEC2", 3);
  f.j["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"] = moved_uv;
  f.j["meshes"][0]["primitives"][0]["targets"][1]["TEXCOORD_0"] = moved_uv;
  f.j.erase("buffers");  // written again with the new bytes
  const std::string path = f.write("morph_uv");
  std::vector<std::string> plain, read;
  load_gltf(path, &plain);
  EXPECT_TRUE(plain.empty()) << ::testing::PrintToString(plain) << ": nothing reads TEXCOORD_0";
  LoadOptions o;
  o.attributes = kAttributeTexcoord0;
  load_gltf(path, &read, o);
  ASSERT_EQ(read.size(), 1u) << ::testing::PrintToString(read);
  EXPECT_NE(read[0].find("mesh 0 primitive 0's morph targets move TEXCOORD_0, which rayfold does not morph"),
            std::string::npos)
      << read[0];
}

TEST(Loader, GpuInstancesEqualTheSameInstancesWrittenAsNodes) {
  // EXT_mesh_gpu_instancing (used, not required): three copies of a
  // triangle, each with its own translation, rotation and scale under a
  // moved node; written again as three child nodes with the same TRS.
  const std::vector<glm::vec3> t = {{0, 0, 0}, {3, 0, -1}, {-2, 1, 0.5f}};
  const std::vector<float> r = {0, 0, 0, 1, 0, 0.38268343f, 0, 0.92387953f, 0, 0, 0.70710677f, 0.70710677f};
  const std::vector<glm::vec3> sc = {{1, 1, 1}, {2, 2, 2}, {1, -1, 0.5f}};
  testing::GltfFile gpu;
  gpu.one_triangle();
  const int ta = gpu.accessor(gpu.view(t.data(), 36), 5126, "VEC3", 3);
  const int ra = gpu.accessor(gpu.view(r.data(), 48), 5126, "VEC4", 3);
  const int sa = gpu.accessor(gpu.view(sc.data(), 36), 5126, "VEC3", 3);
  gpu.j["nodes"][0]["translation"] = {0.25, 0.0, -4.0};
  gpu.j["nodes"][0]["name"] = "crowd";
  gpu.j["nodes"][0]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"] = {
      {"TRANSLATION", ta}, {"ROTATION", ra}, {"SCALE", sa}};
  gpu.j["extensionsUsed"] = {"EXT_mesh_gpu_instancing"};
  testing::GltfFile plain;
  plain.one_triangle();
  plain.j["nodes"][0] = {{"translation", {0.25, 0.0, -4.0}}, {"children", {1, 2, 3}}};
  for (int i = 0; i < 3; ++i)
    plain.j["nodes"].push_back({{"mesh", 0},
                                {"translation", {t[i].x, t[i].y, t[i].z}},
                                {"rotation", {r[4 * i], r[4 * i + 1], r[4 * i + 2], r[4 * i + 3]}},
                                {"scale", {sc[i].x, sc[i].y, sc[i].z}}});
  const Scene a = load_gltf(gpu.write("gpu_instancing")), b = load_gltf(plain.write("gpu_instancing_plain"));
  ASSERT_EQ(a.instances.size(), 3u);
  ASSERT_EQ(b.instances.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(a.instances[i].world_from_object, b.instances[i].world_from_object) << "instance " << i;
    EXPECT_EQ(a.instances[i].name, "crowd[" + std::to_string(i) + "]");
  }
  CameraSpec spec;
  spec.eye = {0, 0, 6};
  spec.look_at = {0, 0, -4};
  const Camera cam = make_camera(spec, 48, 32);
  PipelineOptions cpu;
  cpu.backend = Backend::cpu;
  const auto ha = Pipeline(a, cpu).render(cam).hits, hb = Pipeline(b, cpu).render(cam).hits;
  EXPECT_EQ(testing::compare_hits(ha, hb, 48), "");
  std::set<uint32_t> seen;
  for (const rf_pixel_hit& h : ha)
    if (h.instance != RF_INVALID) seen.insert(h.instance);
  EXPECT_EQ(seen.size(), 3u) << "every copy is in view";
}

TEST(Loader, SkinnedMeshesAtTheDefaultPose) {
  // Joint 0 at (0, 0, -2), joint 1 its child 3 up; no inverse bind
  // matrices. Vertex 0 follows joint 0, vertex 1 joint 1, vertex 2 half of
  // each. The skinned node's own transform (a far translation) is ignored,
  // as glTF specifies.
  testing::GltfFile f;
  f.one_triangle();
  const uint8_t joints[12] = {0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0};
  const float weights[12] = {1, 0, 0, 0, 1, 0, 0, 0, 0.5f, 0.5f, 0, 0};
  const int ja = f.accessor(f.view(joints, sizeof joints), 5121, "VEC4", 3);
  const int wa = f.accessor(f.view(weights, sizeof weights), 5126, "VEC4", 3);
  f.j["meshes"][0]["primitives"][0]["attributes"]["JOINTS_0"] = ja;
  f.j["meshes"][0]["primitives"][0]["attributes"]["WEIGHTS_0"] = wa;
  f.j["nodes"][0]["skin"] = 0;
  f.j["nodes"][0]["translation"] = {100, 0, 0};
  f.j["nodes"].push_back({{"translation", {0, 0, -2}}, {"children", {2}}});
  f.j["nodes"].push_back({{"translation", {0, 3, 0}}});
  f.j["skins"] = {{{"joints", {1, 2}}}};
  f.j["scenes"] = {{{"nodes", {0, 1}}}};
  const Scene scene = load_gltf(f.write("skinned"));
  ASSERT_EQ(scene.instances.size(), 1u);
  EXPECT_EQ(scene.instances[0].world_from_object, Xform(1.0));
  EXPECT_EQ(scene.meshes[scene.instances[0].mesh].positions,
            (std::vector<glm::vec3>{{0, 0, -2}, {1, 3, -2}, {0, 2.5f, -2}}));

  // A skin whose every vertex follows one joint with an inverse bind matrix
  // renders as the mesh under joint * inverse bind, written plainly.
  testing::GltfFile g;
  g.one_triangle();
  const uint8_t zero[12] = {0};
  const float one[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
  const float ibm[16] = {2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0.5f, 0, 0, 1};  // column-major: scale 2, x + 0.5
  g.j["meshes"][0]["primitives"][0]["attributes"]["JOINTS_0"] = g.accessor(g.view(zero, sizeof zero), 5121, "VEC4", 3);
  g.j["meshes"][0]["primitives"][0]["attributes"]["WEIGHTS_0"] = g.accessor(g.view(one, sizeof one), 5126, "VEC4", 3);
  g.j["nodes"][0]["skin"] = 0;
  g.j["nodes"].push_back({{"translation", {-0.5, 0.25, -3}}, {"rotation", {0, 0, 0.38268343, 0.92387953}}});
  g.j["skins"] = {{{"joints", {1}}, {"inverseBindMatrices", g.accessor(g.view(ibm, sizeof ibm), 5126, "MAT4", 1)}}};
  g.j["scenes"] = {{{"nodes", {0, 1}}}};
  testing::GltfFile plain;
  plain.one_triangle();
  plain.j["nodes"][0] = {
      {"children", {1}}, {"translation", {-0.5, 0.25, -3}}, {"rotation", {0, 0, 0.38268343, 0.92387953}}};
  plain.j["nodes"].push_back({{"mesh", 0}, {"matrix", {2, 0, 0, 0, 0, 2, 0, 0, 0, 0, 2, 0, 0.5, 0, 0, 1}}});
  CameraSpec spec;
  spec.eye = {0, 0.5, -1};
  spec.look_at = {0, 0.5, -3};
  const Camera cam = make_camera(spec, 40, 30);
  PipelineOptions cpu;
  cpu.backend = Backend::cpu;
  const auto a = Pipeline(load_gltf(g.write("skinned_one_joint")), cpu).render(cam).hits;
  const auto b = Pipeline(load_gltf(plain.write("skinned_one_joint_plain")), cpu).render(cam).hits;
  size_t same = 0, hits = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    hits += b[i].instance != RF_INVALID;
    same += a[i].instance == b[i].instance && a[i].primitive == b[i].primitive;
  }
  EXPECT_GT(hits, a.size() / 20) << "the triangle is in view";
  // Skinning rounds world-space vertices once, the plain file rounds nothing
  // before the trace: the same pixels, up to silhouette rounding.
  EXPECT_GE(same, a.size() - a.size() / 100);
}

// Two scenes, the second showing the mesh twice and two cameras, the first
// orthographic.
testing::GltfFile scenes_and_cameras() {
  testing::GltfFile f;
  f.one_triangle();
  f.j["cameras"] = {{{"type", "orthographic"}, {"orthographic", {{"xmag", 1}, {"ymag", 1}, {"znear", 0}, {"zfar", 9}}}},
                    {{"type", "perspective"}, {"perspective", {{"yfov", 0.5}, {"znear", 0.1}}}}};
  f.j["nodes"].push_back({{"mesh", 0}, {"translation", {2, 0, 0}}});
  f.j["nodes"].push_back({{"camera", 0}, {"name", "top"}, {"translation", {0, 0, 5}}});
  f.j["nodes"].push_back({{"camera", 1}, {"name", "front"}, {"translation", {0, 0, 7}}});
  f.j["scenes"] = {{{"nodes", {0}}, {"name", "one"}}, {{"nodes", {0, 1, 2, 3}}, {"name", "two"}}};
  f.j["scene"] = 0;
  return f;
}

TEST(Loader, ScenesAndCamerasAreChosenAndListed) {
  const std::string path = scenes_and_cameras().write("scenes_and_cameras");
  const Scene first = load_gltf(path);
  EXPECT_EQ(first.scene_index, 0);
  EXPECT_EQ(first.scene_names, (std::vector<std::string>{"one", "two"}));
  EXPECT_EQ(first.instances.size(), 1u);
  EXPECT_FALSE(first.camera.has_value());
  LoadOptions two;
  two.scene = 1;
  std::vector<std::string> warnings;
  const Scene second = load_gltf(path, &warnings, two);
  EXPECT_EQ(second.instances.size(), 2u);
  ASSERT_EQ(second.cameras.size(), 2u);
  EXPECT_FALSE(second.cameras[0].perspective);
  EXPECT_EQ(second.cameras[1].name, "front");
  ASSERT_TRUE(second.camera.has_value()) << "the file's first camera, orthographic";
  EXPECT_EQ(second.camera->eye, glm::dvec3(0, 0, 5));
  EXPECT_TRUE(second.camera->orthographic);
  EXPECT_TRUE(warnings.empty());
  two.camera = 1;
  const Scene front = load_gltf(path, nullptr, two);
  EXPECT_EQ(front.camera->eye, glm::dvec3(0, 0, 7));
  EXPECT_FALSE(front.camera->orthographic);
  EXPECT_NEAR(front.camera->vfov_degrees, 0.5 * 180.0 / M_PI, 1e-12);
  two.camera = 2;
  testing::expect_error_with(path, two, "camera 2 does not exist (the scene shows 2 cameras)");
  two.camera = -1;
  two.scene = 2;
  testing::expect_error_with(path, two, "scene 2 does not exist (the file has 2 scenes)");
}

TEST(Loader, AnimationsSampledAtATime) {
  // Node 0 moves from x = 0 to x = 4 over 2 s (linear); its rotation turns
  // 90 degrees about z (slerp); node 1 steps in scale and follows a cubic
  // spline in y with zero tangents.
  testing::GltfFile f;
  f.one_triangle();
  f.j["nodes"].push_back({{"mesh", 0}});
  const float times[2] = {0, 2};
  const float move[6] = {0, 0, 0, 4, 0, 0};
  const float turn[8] = {0, 0, 0, 1, 0, 0, 0.70710678f, 0.70710678f};
  const float grow[6] = {1, 1, 1, 3, 3, 3};
  const float spline[18] = {0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 5, 0, 0, 0, 0};  // in, value, out per key
  const int tin = f.accessor(f.view(times, 8), 5126, "SCALAR", 2);
  f.j["accessors"][tin]["min"] = {0};
  f.j["accessors"][tin]["max"] = {2};
  const int mv = f.accessor(f.view(move, 24), 5126, "VEC3", 2), tv = f.accessor(f.view(turn, 32), 5126, "VEC4", 2);
  const int gv = f.accessor(f.view(grow, 24), 5126, "VEC3", 2), sv = f.accessor(f.view(spline, 72), 5126, "VEC3", 6);
  f.j["animations"] = {{{"samplers",
                         {{{"input", tin}, {"output", mv}},
                          {{"input", tin}, {"output", tv}},
                          {{"input", tin}, {"output", gv}, {"interpolation", "STEP"}},
                          {{"input", tin}, {"output", sv}, {"interpolation", "CUBICSPLINE"}}}},
                        {"channels",
                         {{{"sampler", 0}, {"target", {{"node", 0}, {"path", "translation"}}}},
                          {{"sampler", 1}, {"target", {{"node", 0}, {"path", "rotation"}}}},
                          {{"sampler", 2}, {"target", {{"node", 1}, {"path", "scale"}}}},
                          {{"sampler", 3}, {"target", {{"node", 1}, {"path", "translation"}}}}}}}};
  f.j["scenes"] = {{{"nodes", {0, 1}}}};
  const std::string path = f.write("animated");
  auto at = [&](double t) {
    LoadOptions o;
    o.time = t;
    return load_gltf(path, nullptr, o);
  };
  const Scene rest = load_gltf(path), half = at(0.5), mid = at(1.0), late = at(9.0);
  EXPECT_EQ(rest.instances[0].world_from_object, Xform(1.0)) << "no time: the rest pose";
  const Xform& m = half.instances[0].world_from_object;
  EXPECT_NEAR(m[3][0], 1.0, 1e-12);
  // 22.5 degrees about z at a quarter of the way: slerp, not a linear blend.
  EXPECT_NEAR(std::atan2(m[0][1], m[0][0]) * 180.0 / M_PI, 22.5, 1e-5);
  EXPECT_EQ(half.instances[1].world_from_object[0][0], 1.0) << "a step holds the first key until the second";
  // Hermite with zero tangents at the middle: halfway between 1 and 5.
  EXPECT_NEAR(mid.instances[1].world_from_object[3][1], 3.0, 1e-12);
  EXPECT_NEAR(late.instances[0].world_from_object[3][0], 4.0, 1e-12) << "after the last key: its value";
  EXPECT_EQ(late.instances[1].world_from_object[0][0], 3.0);
  // One file read once, posed at any time: the same scenes as loading it at
  // each time, meshes shared (only transforms move).
  rayfold::core::GltfFile file(path);
  EXPECT_TRUE(file.animated());
  EXPECT_EQ(file.animation_end(), 2.0);
  for (double t : {0.5, 1.0, 9.0, 0.5}) {
    const Scene posed = file.scene_at(t), loaded = at(t);
    ASSERT_EQ(posed.instances.size(), loaded.instances.size());
    for (size_t i = 0; i < posed.instances.size(); ++i)
      EXPECT_EQ(posed.instances[i].world_from_object, loaded.instances[i].world_from_object) << t;
    EXPECT_TRUE(same_geometry(posed, rest)) << t;
  }
  EXPECT_EQ(file.scene_at(NAN).instances[0].world_from_object, Xform(1.0)) << "back to rest after a pose";
  f.j["animations"][0]["channels"][0]["target"]["path"] = "color";
  LoadOptions o;
  o.time = 1.0;
  testing::expect_error_with(f.write("animated_bad_path"), o, "animates 'color'");
}

TEST(Loader, AnimatedMorphWeightsChangeTheGeometry) {
  testing::GltfFile f;
  f.one_triangle();
  const int t0 = f.positions({{2, 0, 0}, {2, 0, 0}, {2, 0, 0}});
  f.j["meshes"][0]["primitives"][0]["targets"] = {{{"POSITION", t0}}};
  f.j["meshes"][0]["weights"] = {0.0};
  const float times[2] = {0, 1}, weights[2] = {0, 1};
  const int tin = f.accessor(f.view(times, 8), 5126, "SCALAR", 2);
  f.j["accessors"][tin]["min"] = {0};
  f.j["accessors"][tin]["max"] = {1};
  const int wv = f.accessor(f.view(weights, 8), 5126, "SCALAR", 2);
  f.j["animations"] = {{{"samplers", {{{"input", tin}, {"output", wv}}}},
                        {"channels", {{{"sampler", 0}, {"target", {{"node", 0}, {"path", "weights"}}}}}}}};
  rayfold::core::GltfFile file(f.write("animated_morph"));
  const Scene a = file.scene_at(0.0), b = file.scene_at(0.5), c = file.scene_at(0.5);
  EXPECT_FALSE(same_geometry(a, b));
  EXPECT_TRUE(same_geometry(b, c));
  EXPECT_EQ(b.meshes[0].positions[0].x - a.meshes[0].positions[0].x, 1.0f);
}

}  // namespace
}  // namespace rayfold::core
