// Bad input never crashes and never half-loads: every broken file gives an
// InputError naming the file and the rule it breaks. Legal but odd files
// load and render on both backends.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>

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
using testing::expect_error_with;
using testing::GltfFile;

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), {});
}

std::string write_bytes(const std::string& name, const std::string& bytes) {
  const std::string p = (testing::temp_dir() / name).string();
  std::ofstream(p, std::ios::binary).write(bytes.data(), bytes.size());
  return p;
}

std::string small_glb() {
  GenOptions gen;
  gen.objects = 3;
  gen.triangle_budget = 500;
  const std::string p = (testing::temp_dir() / "small.glb").string();
  write_glb(generate_atrium(gen), p);
  return read_bytes(p);
}

// A one-triangle file broken by `edit` must be refused with `expect` in
// its message.
struct EditCase {
  const char* name;
  const char* expect;
  std::function<void(GltfFile&)> edit;
};

// The message of the InputError loading `path` throws, the path replaced
// by "FILE"; empty when it loads.
std::string error_text(const std::string& path, const LoadOptions& options) {
  try {
    load_gltf(path, nullptr, options);
  } catch (const InputError& e) {
    std::string what = e.what();
    for (size_t at; (at = what.find(path)) != std::string::npos;) what.replace(at, path.size(), "FILE");
    return what;
  }
  return "";
}

// The error of f as written, on one thread, and of f with 600 KB of
// padding in its JSON's extras, which the loader reads with tinygltf's
// parse beside its checks' (gltf/document.cpp): the same message.
void expect_error_both_ways(GltfFile& f, const std::string& name, const std::string& expect) {
  LoadOptions one;
  one.threads = 1;
  const std::string path = f.write(name);
  expect_error_with(path, one, expect);
  if (!f.j.is_object()) return;
  const std::string alone = error_text(path, one);
  f.j["extras"] = {{"padding", std::string(size_t{600} << 10, ' ')}};
  const std::string padded = f.write(name + "_padded");
  LoadOptions two;
  two.threads = 2;
  const size_t reads = gltf::Loader::side_by_side_reads();
  const std::string beside = error_text(padded, two);
  EXPECT_EQ(beside, alone) << "on one thread and side by side";
  EXPECT_EQ(gltf::Loader::side_by_side_reads(), reads + 1) << "the padded file was not read side by side";
}

void expect_errors(const std::vector<EditCase>& cases) {
  for (const EditCase& c : cases) {
    SCOPED_TRACE(c.name);
    GltfFile f;
    f.one_triangle();
    c.edit(f);
    expect_error_both_ways(f, c.name, c.expect);
  }
}

void put_u32(std::string& b, size_t at, uint32_t v) { std::memcpy(&b[at], &v, 4); }

TEST(BadInput, GlbContainer) {
  const std::string good = small_glb();
  ASSERT_GT(good.size(), 100u);
  // Truncated anywhere: in the header, the JSON chunk, the binary chunk.
  for (size_t cut : {size_t(3), size_t(11), size_t(19), size_t(40), good.size() / 2, good.size() - 1})
    expect_error(write_bytes("cut" + std::to_string(cut) + ".glb", good.substr(0, cut)), "");
  std::string b = good;
  put_u32(b, 4, 1);  // version 1
  expect_error(write_bytes("v1.glb", b), "");
  b = good;
  put_u32(b, 8, static_cast<uint32_t>(good.size() + 1000));  // total length past the file
  expect_error(write_bytes("len.glb", b), "");
  b = good;
  put_u32(b, 12, 0x7FFFFFF0u);  // JSON chunk length absurd
  expect_error(write_bytes("chunk.glb", b), "");
  b = good;
  put_u32(b, 16, 0x12345678u);  // chunk type not JSON
  expect_error(write_bytes("type.glb", b), "");
}

TEST(BadInput, JsonAndBuffers) {
  expect_error(write_bytes("trunc.gltf", R"({"asset":{"version":"2.0"},"nodes":[{)"), "");
  expect_error(write_bytes("notjson.gltf", "\x01\x02\x03 nonsense"), "");
  expect_error(write_bytes("array.gltf", "[1, 2, 3]"), "");
  {
    GltfFile f;
    f.one_triangle();
    f.j["buffers"] = {{{"uri", "does_not_exist.bin"}, {"byteLength", 100}}};
    // Once tinygltf's raw "File not found : does_not_exist.bin".
    expect_error(f.write("missing_bin"), "buffer file \"does_not_exist.bin\" does not exist (looked for ");
  }
  {
    GltfFile f;
    f.one_triangle();
    f.j["buffers"] = {{{"uri", "short.bin"}, {"byteLength", 100000}}};  // the file holds 48 bytes
    expect_error(f.write("short"), "");
  }
  {
    GltfFile f;
    f.one_triangle();
    f.j["bufferViews"][0]["byteLength"] = 100000;  // view past its buffer
    expect_error(f.write("view_past"), "runs past its buffer");
  }
  {
    GltfFile f;
    f.one_triangle();
    f.j["bufferViews"][0]["buffer"] = 5;
    expect_error(f.write("buffer_ref"), "");
  }
}

TEST(BadInput, Accessors) {
  const std::vector<EditCase> cases = {
      {"count_past_view", "runs past its buffer view", [](GltfFile& f) { f.j["accessors"][0]["count"] = 4; }},
      {"absurd_count", "", [](GltfFile& f) { f.j["accessors"][0]["count"] = 1ull << 40; }},
      {"offset_past_view", "", [](GltfFile& f) { f.j["accessors"][0]["byteOffset"] = 1000; }},
      {"misaligned", "aligned", [](GltfFile& f) { f.j["accessors"][0]["byteOffset"] = 2; }},
      {"view_ref", "", [](GltfFile& f) { f.j["accessors"][0]["bufferView"] = 9; }},
      {"position_vec2", "must be VEC3", [](GltfFile& f) { f.j["accessors"][0]["type"] = "VEC2"; }},
      {"position_short", "only with KHR_mesh_quantization",
       [](GltfFile& f) { f.j["accessors"][0]["componentType"] = 5123; }},
      {"position_uint", "must be FLOAT or (normalized) byte or short",
       [](GltfFile& f) { f.j["accessors"][0]["componentType"] = 5125; }},
      {"indices_float", "", [](GltfFile& f) { f.j["accessors"][1]["componentType"] = 5126; }},
      {"indices_signed", "", [](GltfFile& f) { f.j["accessors"][1]["componentType"] = 5122; }},
      {"indices_vec3", "SCALAR", [](GltfFile& f) { f.j["accessors"][1]["type"] = "VEC3"; }},
      {"index_stride", "byteStride", [](GltfFile& f) { f.j["bufferViews"][1]["byteStride"] = 4; }},
      {"odd_stride", "byteStride", [](GltfFile& f) { f.j["bufferViews"][0]["byteStride"] = 14; }},
      {"huge_stride", "", [](GltfFile& f) { f.j["bufferViews"][0]["byteStride"] = 256; }},
      {"sparse_count", "sparse with 5 substitutions for 3 elements",
       [](GltfFile& f) {
         f.j["accessors"][0]["sparse"] = {
             {"count", 5}, {"indices", {{"bufferView", 1}, {"componentType", 5123}}}, {"values", {{"bufferView", 0}}}};
       }},
      {"sparse_index_float", "sparse indices must be unsigned",
       [](GltfFile& f) {
         f.j["accessors"][0]["sparse"] = {
             {"count", 1}, {"indices", {{"bufferView", 1}, {"componentType", 5126}}}, {"values", {{"bufferView", 0}}}};
       }},
      {"sparse_values_view", "sparse values",
       [](GltfFile& f) {
         f.j["accessors"][0]["sparse"] = {
             {"count", 1}, {"indices", {{"bufferView", 1}, {"componentType", 5123}}}, {"values", {{"bufferView", 9}}}};
       }},
      {"morph_weights", "morph targets but 2 weights",
       [](GltfFile& f) {
         f.j["meshes"][0]["primitives"][0]["targets"] = {{{"POSITION", 0}}};
         f.j["meshes"][0]["weights"] = {0.5, 0.5};
       }},
      {"position_ref", "", [](GltfFile& f) { f.j["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 7; }},
      {"index_ref", "", [](GltfFile& f) { f.j["meshes"][0]["primitives"][0]["indices"] = 7; }},
      {"mode", "", [](GltfFile& f) { f.j["meshes"][0]["primitives"][0]["mode"] = 9; }},
      {"no_position", "", [](GltfFile& f) { f.j["meshes"][0]["primitives"][0]["attributes"].erase("POSITION"); }},
  };
  expect_errors(cases);
}

TEST(BadInput, IndicesAndPositions) {
  {
    GltfFile f;
    f.one_triangle({0, 1, 3});
    expect_error(f.write("index_range"), "index 2 is 3, past the 3 vertices");
  }
  {
    // The first index past the vertices is named, not the largest.
    GltfFile f;
    f.one_triangle({0, 5, 1, 0, 1, 9});
    expect_error(f.write("index_first"), "index 1 is 5, past the 3 vertices");
  }
  for (float bad : {NAN, INFINITY, -INFINITY}) {
    GltfFile f;
    const std::vector<glm::vec3> p = {{0, 0, 0}, {1, bad, 0}, {0, 1, 0}};
    const int a = f.accessor(f.view(p.data(), 36), 5126, "VEC3", 3);
    f.j["meshes"] = json::array({testing::mesh({testing::prim(a)})});
    f.j["nodes"] = json::array({testing::node_with_mesh(0)});
    expect_error(f.write("nonfinite"), "not finite");
  }
}

TEST(BadInput, Nodes) {
  const std::vector<EditCase> cases = {
      {"self_cycle", "cycle",
       [](GltfFile& f) {
         f.j["nodes"][0]["children"] = {0};
         f.j["scenes"] = {{{"nodes", {0}}}};
       }},
      {"long_cycle", "cycle",
       [](GltfFile& f) {
         f.j["nodes"][0]["children"] = {1};
         f.j["nodes"][1] = {{"children", {2}}};
         f.j["nodes"][2] = {{"children", {0}}};
         f.j["scenes"] = {{{"nodes", {0}}}};
       }},
      {"two_parents", "more than one parent",
       [](GltfFile& f) {
         f.j["nodes"][1] = {{"children", {0}}};
         f.j["nodes"][2] = {{"children", {0}}};
         f.j["scenes"] = {{{"nodes", {1, 2}}}};
       }},
      {"child_ref", "", [](GltfFile& f) { f.j["nodes"][0]["children"] = {42}; }},
      {"scene_node_ref", "",
       [](GltfFile& f) {
         f.j["scenes"] = {{{"nodes", {42}}}};
       }},
      {"default_scene", "",
       [](GltfFile& f) {
         f.j["scenes"] = {{{"nodes", {0}}}};
         f.j["scene"] = 3;
       }},
      {"default_scene_without_scenes", "\"scene\" is 0 but the file has no scenes",
       [](GltfFile& f) {  // once rendered with exit 0 while --scene 0 on it was an error
         f.j.erase("scenes");
         f.j["scene"] = 0;
       }},
      {"mesh_ref", "mesh 5", [](GltfFile& f) { f.j["nodes"][0]["mesh"] = 5; }},
      {"camera_ref", "", [](GltfFile& f) { f.j["nodes"][0]["camera"] = 3; }},
      {"matrix_and_trs", "both a matrix",
       [](GltfFile& f) {
         f.j["nodes"][0]["matrix"] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
         f.j["nodes"][0]["translation"] = {1, 2, 3};
       }},
      {"matrix_size", "",
       [](GltfFile& f) {
         f.j["nodes"][0]["matrix"] = {1, 0, 0};
       }},
      {"projective", "not affine",
       [](GltfFile& f) { f.j["nodes"][0]["matrix"] = {1, 0, 0, 0.5, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}; }},
      {"zero_quaternion", "",
       [](GltfFile& f) {
         f.j["nodes"][0]["rotation"] = {0, 0, 0, 0};
       }},
      {"scale_size", "",
       [](GltfFile& f) {
         f.j["nodes"][0]["scale"] = {1, 2};
       }},
  };
  for (const EditCase& c : cases) {
    SCOPED_TRACE(c.name);
    GltfFile f;
    f.one_triangle();
    f.j["nodes"][1] = json::object();
    f.j["nodes"][2] = json::object();
    c.edit(f);
    expect_error_both_ways(f, c.name, c.expect);
  }
}

TEST(BadInput, SchemaTypesAreCheckedWithThePathOfTheMember) {
  // tinygltf reads a member of the wrong JSON type as if it were absent: a
  // mesh whose primitives are an object rendered as an empty scene, exit 0.
  const std::vector<EditCase> cases = {
      {"primitives_object", "meshes[0].primitives must be an array of objects (glTF 2.0 schema), not object",
       [](GltfFile& f) { f.j["meshes"][0]["primitives"] = f.j["meshes"][0]["primitives"][0]; }},
      {"children_string", "nodes[0].children must be an array of integers",
       [](GltfFile& f) { f.j["nodes"][0]["children"] = "1"; }},
      {"count_string", "accessors[0].count must be an integer (glTF 2.0 schema), not string",
       [](GltfFile& f) { f.j["accessors"][0]["count"] = "3"; }},
      {"nodes_object", ".nodes must be an array of objects",
       [](GltfFile& f) {
         f.j["nodes"] = {{"mesh", 0}};
       }},
      {"position_float", "attributes.POSITION must be an integer",
       [](GltfFile& f) { f.j["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = 0.5; }},
      {"translation_string", "nodes[0].translation must be an array of numbers",
       [](GltfFile& f) {
         f.j["nodes"][0]["translation"] = {1, "2", 3};
       }},
      {"scene_string", ".scene must be an integer", [](GltfFile& f) { f.j["scene"] = "0"; }},
      // Once shown as "(unnamed)": tinygltf reads a name of another type as absent.
      {"scene_name_number", "scenes[0].name must be a string (glTF 2.0 schema), not number",
       [](GltfFile& f) {
         f.j["scenes"] = {{{"nodes", {0}}, {"name", 42}}};
       }},
  };
  expect_errors(cases);
}

TEST(BadInput, GpuInstancing) {
  const float t[6] = {0, 0, 0, 1, 0, 0}, q[4] = {0, 0, 0, 1};
  const std::vector<EditCase> cases = {
      {"gpu_counts", "different numbers of instances",
       [&](GltfFile& f) {
         const int ta = f.accessor(f.view(t, sizeof t), 5126, "VEC3", 2);
         const int ra = f.accessor(f.view(q, sizeof q), 5126, "VEC4", 1);
         f.j["nodes"][0]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"] = {{"TRANSLATION", ta},
                                                                                   {"ROTATION", ra}};
       }},
      {"gpu_rotation_vec3", "ROTATION must be VEC4",
       [&](GltfFile& f) {
         const int ra = f.accessor(f.view(t, sizeof t), 5126, "VEC3", 2);
         f.j["nodes"][0]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"] = {{"ROTATION", ra}};
       }},
      {"gpu_empty", "none of TRANSLATION, ROTATION and SCALE",
       [&](GltfFile& f) { f.j["nodes"][0]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"] = json::object(); }},
      {"gpu_accessor_ref", "does not exist",
       [&](GltfFile& f) {
         f.j["nodes"][0]["extensions"]["EXT_mesh_gpu_instancing"]["attributes"] = {{"SCALE", 42}};
       }},
  };
  expect_errors(cases);
}

TEST(BadInput, Skins) {
  const uint8_t joints[12] = {0, 0, 0, 0, 3, 0, 0, 0, 0, 0, 0, 0};
  const float weights[12] = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
  auto skinned = [&](GltfFile& f) {
    f.j["meshes"][0]["primitives"][0]["attributes"]["JOINTS_0"] = f.accessor(f.view(joints, 12), 5121, "VEC4", 3);
    f.j["meshes"][0]["primitives"][0]["attributes"]["WEIGHTS_0"] = f.accessor(f.view(weights, 48), 5126, "VEC4", 3);
    f.j["nodes"][0]["skin"] = 0;
    f.j["skins"] = {{{"joints", {0}}}};
  };
  const std::vector<EditCase> cases = {
      {"skin_ref", "refers to skin 0, which does not exist", [&](GltfFile& f) { f.j["nodes"][0]["skin"] = 0; }},
      {"skin_joint_range", "refers to joint 3 of 1", skinned},
      {"skin_no_joints", "has no JOINTS_0 and WEIGHTS_0",
       [&](GltfFile& f) {
         f.j["nodes"][0]["skin"] = 0;
         f.j["skins"] = {{{"joints", {0}}}};
       }},
      {"skin_joint_node", "is node 9, which does not exist",
       [&](GltfFile& f) {
         skinned(f);
         f.j["skins"][0]["joints"] = {9};
       }},
  };
  expect_errors(cases);
}

TEST(BadInput, UnsupportedRequiredExtensionsAreNamed) {
  for (const char* ext : {"KHR_gaussian_splatting", "EXT_lights_image_based_geometry"}) {
    GltfFile f;
    f.one_triangle();
    f.j["extensionsUsed"] = {ext};
    f.j["extensionsRequired"] = {ext};
    expect_error(f.write(ext), ext);
  }
  // Compressed geometry is decoded (test_compressed.cpp), used or required:
  // data that is not what the extension says is an error naming it.
  {
    GltfFile f;
    f.one_triangle();
    f.j["extensionsUsed"] = {"KHR_draco_mesh_compression"};
    f.j["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"] = {{"bufferView", 0},
                                                                                     {"attributes", {{"POSITION", 0}}}};
    expect_error(f.write("draco_optional"), "(KHR_draco_mesh_compression): the compressed data does not decode");
  }
  {
    GltfFile f;
    f.one_triangle();
    f.j["extensionsUsed"] = {"EXT_meshopt_compression"};
    f.j["bufferViews"][0]["extensions"]["EXT_meshopt_compression"] = {
        {"buffer", 0}, {"byteLength", 36}, {"byteStride", 12}, {"count", 3}, {"mode", "ATTRIBUTES"}};
    expect_error(f.write("meshopt_optional"), "(EXT_meshopt_compression): the compressed data does not decode");
  }
  // A required extension that cannot change geometry is fine.
  GltfFile f;
  f.one_triangle();
  f.j["extensionsUsed"] = {"KHR_materials_emissive_strength"};
  f.j["extensionsRequired"] = {"KHR_materials_emissive_strength"};
  EXPECT_EQ(load_gltf(f.write("materials_ext")).triangle_count(), 1u);
}

// Legal but odd files load, warn where useful, and render on both backends.
TEST(OddInput, RendersWithWarnings) {
  auto render_both = [](const Scene& scene) {
    CameraSpec spec;
    spec.eye = {0.3, 0.4, 5};
    spec.look_at = {0.3, 0.4, 0};
    const Camera cam = make_camera(spec, 33, 17);
    PipelineOptions cpu;
    cpu.backend = Backend::cpu;
    Pipeline a(scene, cpu), b(scene, PipelineOptions{});
    const RenderResult ra = a.render(cam, 1, FrameOptions{Fold::xy});
    const RenderResult rb = b.render(cam, 1, FrameOptions{Fold::xy});
    EXPECT_EQ(testing::compare_hits(ra.hits, rb.hits, cam.width), "");
    return ra;
  };
  std::vector<std::string> w;
  {
    GltfFile f;  // an empty scene
    w.clear();
    const Scene s = load_gltf(f.write("empty"), &w);
    EXPECT_EQ(s.triangle_count(), 0u);
    EXPECT_FALSE(w.empty());
    for (const rf_pixel_hit& h : render_both(s).hits) EXPECT_EQ(h.instance, RF_INVALID);
  }
  {
    GltfFile f;  // points only
    const int p = f.positions({{0, 0, 0}, {1, 1, 1}});
    f.j["meshes"] = json::array({testing::mesh({testing::prim(p, -1, 0)})});
    f.j["nodes"] = json::array({testing::node_with_mesh(0)});
    w.clear();
    const Scene s = load_gltf(f.write("points"), &w);
    EXPECT_EQ(s.triangle_count(), 0u);
    EXPECT_GE(w.size(), 2u);
    render_both(s);
  }
  {
    GltfFile f;  // a zero-scale node beside a normal one, a mirrored node, degenerate triangles
    const int p = f.positions({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 2, 0}});
    const std::vector<uint16_t> idx = {0, 1, 2, 0, 0, 1, 3, 3, 3};
    const int i = f.accessor(f.view(idx.data(), idx.size() * 2), 5123, "SCALAR", idx.size());
    f.j["meshes"] = json::array({testing::mesh({testing::prim(p, i)})});
    json zero = testing::node_with_mesh(0), mirrored = testing::node_with_mesh(0), plain = testing::node_with_mesh(0);
    zero["scale"] = {1, 0, 1};
    mirrored["scale"] = {-1, 1, 1};
    f.j["nodes"] = json::array({zero, mirrored, plain});
    w.clear();
    const Scene s = load_gltf(f.write("odd"), &w);
    ASSERT_EQ(s.instances.size(), 3u);
    bool warned_zero = false;
    for (const std::string& m : w) warned_zero |= m.find("zero scale") != std::string::npos;
    EXPECT_TRUE(warned_zero);
    const RenderResult r = render_both(s);
    size_t seen[3] = {0, 0, 0};
    for (const rf_pixel_hit& h : r.hits) {
      if (h.instance == RF_INVALID) continue;
      ASSERT_LT(h.instance, 3u);
      seen[h.instance]++;
      EXPECT_EQ(h.primitive, 0u) << "only the first triangle has area";
      EXPECT_TRUE(std::isfinite(h.z) && std::isfinite(h.nx) && std::isfinite(h.u));
    }
    EXPECT_EQ(seen[0], 0u) << "a zero-scale instance is hidden";
    EXPECT_GT(seen[1], 0u);
    EXPECT_GT(seen[2], 0u);
  }
}

}  // namespace
}  // namespace rayfold::core
