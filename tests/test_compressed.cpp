// Compressed glTF geometry (scene/gltf_decompress.h): meshopt buffer views and
// Draco primitives decode to the same scene as the uncompressed file, whether
// written by hand with meshoptimizer's encoders or by the tools users run
// (gltfpack, draco_transcoder); bad compressed data is an InputError.
#include <gtest/gtest.h>
#include <meshoptimizer.h>

#include <cstdlib>
#include <filesystem>
#include <set>

#include "gltf_fixture.h"
#include "reference/cpu_tracer.h"
#include "pipeline/pipeline.h"
#include "test_util.h"

namespace rayfold::core {
namespace {

using nlohmann::json;
using testing::GltfFile;

// Turns view `vi` of f into a meshopt-compressed view of `count` elements of
// `stride` bytes: the encoded bytes go into buffer 0, the view itself points
// into the uri-less fallback buffer 1, as gltfpack writes it.
void compress_view(GltfFile& f, int vi, const std::vector<unsigned char>& encoded, size_t count, size_t stride,
                   const char* mode, const char* filter = "NONE") {
  const int enc = f.view(encoded.data(), encoded.size());
  json ev = f.j["bufferViews"][enc];
  f.j["bufferViews"].erase(f.j["bufferViews"].begin() + enc);
  json& v = f.j["bufferViews"][vi];
  v["buffer"] = 1;
  v["byteOffset"] = 0;
  v["byteLength"] = count * stride;
  json ext = {{"buffer", 0},
              {"byteOffset", ev["byteOffset"]},
              {"byteLength", ev["byteLength"]},
              {"byteStride", stride},
              {"count", count},
              {"mode", mode}};
  if (std::string(filter) != "NONE") ext["filter"] = filter;
  v["extensions"] = {{"EXT_meshopt_compression", ext}};
}

// A closed cube mesh as two primitives: u32 TRIANGLES indices and u16 ones.
struct CubeFile {
  GltfFile f;
  Mesh cube = testing::closed_cube(3);
  int pos_view = -1, tri_view = -1, seq_view = -1;
  size_t half = 0;

  CubeFile() {
    const int pos = f.positions(cube.positions);
    pos_view = f.j["accessors"][pos]["bufferView"];
    half = (cube.indices.size() / 6) * 3;
    std::vector<uint32_t> first(cube.indices.begin(), cube.indices.begin() + half);
    std::vector<uint16_t> second(cube.indices.begin() + half, cube.indices.end());
    tri_view = f.view(first.data(), first.size() * 4);
    seq_view = f.view(second.data(), second.size() * 2);
    const int a = f.accessor(tri_view, 5125, "SCALAR", first.size());
    const int b = f.accessor(seq_view, 5123, "SCALAR", second.size());
    f.j["meshes"].push_back(testing::mesh({testing::prim(pos, a), testing::prim(pos, b)}));
    f.j["nodes"].push_back(testing::node_with_mesh(0));
  }

  // Compresses all three views (positions with `filter`) and declares the
  // extension and the fallback buffer.
  void compress(const char* filter) {
    const size_t n = cube.positions.size();
    std::vector<float> p;
    for (const glm::vec3& v : cube.positions) p.insert(p.end(), {v.x, v.y, v.z});
    if (std::string(filter) == "EXPONENTIAL") {
      std::vector<float> encoded(p.size());
      meshopt_encodeFilterExp(encoded.data(), n, 12, 15, p.data());
      p = encoded;
    }
    std::vector<unsigned char> vb(meshopt_encodeVertexBufferBound(n, 12));
    vb.resize(meshopt_encodeVertexBuffer(vb.data(), vb.size(), p.data(), n, 12));
    compress_view(f, pos_view, vb, n, 12, "ATTRIBUTES", filter);
    std::vector<uint32_t> first(cube.indices.begin(), cube.indices.begin() + half);
    std::vector<unsigned char> ib(meshopt_encodeIndexBufferBound(first.size(), n));
    ib.resize(meshopt_encodeIndexBuffer(ib.data(), ib.size(), first.data(), first.size()));
    compress_view(f, tri_view, ib, first.size(), 4, "TRIANGLES");
    std::vector<uint32_t> second(cube.indices.begin() + half, cube.indices.end());
    std::vector<unsigned char> sb(meshopt_encodeIndexSequenceBound(second.size(), n));
    sb.resize(meshopt_encodeIndexSequence(sb.data(), sb.size(), second.data(), second.size()));
    compress_view(f, seq_view, sb, second.size(), 2, "INDICES");
    f.j["extensionsUsed"] = {"EXT_meshopt_compression"};
    f.j["extensionsRequired"] = {"EXT_meshopt_compression"};
  }

  std::string write(const std::string& name) {
    size_t fallback = 0;
    for (const json& v : f.j["bufferViews"])
      if (v["buffer"] == 1)
        fallback = std::max<size_t>(fallback, v["byteOffset"].get<size_t>() + v["byteLength"].get<size_t>());
    if (fallback) {
      f.j["buffers"] = {
          {{"uri", name + ".bin"}, {"byteLength", f.bin.size() + 64}},
          {{"byteLength", fallback}, {"extensions", {{"EXT_meshopt_compression", {{"fallback", true}}}}}}};
      f.bin.resize(f.bin.size() + 64, 0);
    }
    return f.write(name);
  }
};

// Each triangle's corners rotated to start at the smallest index.
std::vector<uint32_t> rotated_to_smallest(const std::vector<uint32_t>& idx) {
  std::vector<uint32_t> out(idx.size());
  for (size_t t = 0; t + 2 < idx.size(); t += 3) {
    const size_t first = std::min_element(idx.begin() + t, idx.begin() + t + 3) - (idx.begin() + t);
    for (size_t k = 0; k < 3; ++k) out[t + k] = idx[t + (first + k) % 3];
  }
  return out;
}

TEST(Compressed, MeshoptViewsDecodeToTheUncompressedScene) {
  CubeFile plain;
  const Scene expected = load_gltf(plain.write("meshopt_plain"));
  CubeFile packed;
  packed.compress("NONE");
  const Scene got = load_gltf(packed.write("meshopt_packed"));
  ASSERT_EQ(got.meshes.size(), 1u);
  EXPECT_EQ(got.meshes[0].positions, expected.meshes[0].positions);
  // meshopt's index codec may rotate a triangle's corners (never its winding).
  EXPECT_EQ(rotated_to_smallest(got.meshes[0].indices), rotated_to_smallest(expected.meshes[0].indices));
  EXPECT_GT(got.meshes[0].indices.size(), 100u);
}

TEST(Compressed, MeshoptExponentialFilterDecodesAsMeshoptDoes) {
  CubeFile packed;
  packed.compress("EXPONENTIAL");
  const Scene got = load_gltf(packed.write("meshopt_exp"));
  // What meshoptimizer itself makes of the filtered values.
  std::vector<float> p;
  for (const glm::vec3& v : packed.cube.positions) p.insert(p.end(), {v.x, v.y, v.z});
  std::vector<float> filtered(p.size());
  meshopt_encodeFilterExp(filtered.data(), packed.cube.positions.size(), 12, 15, p.data());
  meshopt_decodeFilterExp(filtered.data(), packed.cube.positions.size(), 12);
  // Both primitives read the one position accessor.
  const size_t n = packed.cube.positions.size();
  ASSERT_EQ(got.meshes[0].positions.size(), 2 * n);
  for (size_t i = 0; i < 2 * n; ++i)
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(got.meshes[0].positions[i][k], filtered[3 * (i % n) + k]) << i;
      EXPECT_NEAR(got.meshes[0].positions[i][k], p[3 * (i % n) + k], 1e-4) << i;
    }
}

TEST(Compressed, BadMeshoptDataIsAnInputErrorNamingTheView) {
  {
    CubeFile packed;
    packed.compress("NONE");
    // Garbage where the vertex stream starts.
    const size_t at = packed.f.j["bufferViews"][packed.pos_view]["extensions"]["EXT_meshopt_compression"]["byteOffset"];
    for (size_t i = 0; i < 16; ++i) packed.f.bin[at + i] = 0xFF;
    testing::expect_error(packed.write("meshopt_garbage"), "does not decode");
  }
  {
    CubeFile packed;
    packed.compress("NONE");
    packed.f.j["bufferViews"][packed.tri_view]["extensions"]["EXT_meshopt_compression"]["mode"] = "QUADS";
    testing::expect_error(packed.write("meshopt_mode"), "is not ATTRIBUTES, TRIANGLES or INDICES");
  }
  {
    CubeFile packed;
    packed.compress("NONE");
    packed.f.j["bufferViews"][packed.pos_view]["extensions"]["EXT_meshopt_compression"]["count"] = 1u << 30;
    testing::expect_error(packed.write("meshopt_count"), "do not fit the view");
  }
  {
    // A view into the fallback buffer that nothing decodes.
    CubeFile packed;
    packed.compress("NONE");
    packed.f.j["bufferViews"][packed.tri_view].erase("extensions");
    testing::expect_error(packed.write("meshopt_fallback"), "meshopt fallback buffer, which holds no data");
  }
}

TEST(Compressed, DracoGarbageIsAnInputErrorNamingThePrimitive) {
  GltfFile f;
  f.one_triangle();
  const std::vector<unsigned char> junk(64, 0x5A);
  const int v = f.view(junk.data(), junk.size());
  f.j["meshes"][0]["primitives"][0]["extensions"] = {
      {"KHR_draco_mesh_compression", {{"bufferView", v}, {"attributes", {{"POSITION", 0}}}}}};
  f.j["extensionsUsed"] = {"KHR_draco_mesh_compression"};
  testing::expect_error(f.write("draco_junk"), "mesh 0 primitive 0 (KHR_draco_mesh_compression): the compressed");
}

TEST(Compressed, ImagesWithoutDataAreNoConcernOfAGeometryLoader) {
  // gltfpack writes "images": [{}] for textures it could not find; tinygltf
  // refuses those, rayfold never decodes images.
  GltfFile f;
  f.one_triangle();
  f.j["images"] = {json::object(), json::object()};
  const Scene s = load_gltf(f.write("empty_images"));
  EXPECT_EQ(s.triangle_count(), 1u);
}

bool have_tool(const char* name) {
  return std::system((std::string("command -v ") + name + " >/dev/null").c_str()) == 0;
}

// Every instance's triangles in world space, each as its three corners
// rotated to start at the smallest (winding kept): the scene as a set.
std::multiset<std::vector<double>> world_triangles(const Scene& s) {
  std::multiset<std::vector<double>> out;
  for (const Instance& inst : s.instances) {
    const Mesh& m = s.meshes[inst.mesh];
    for (size_t t = 0; t < m.triangle_count(); ++t) {
      std::vector<std::vector<double>> c;
      for (int k = 0; k < 3; ++k) {
        const glm::dvec3 p = transform_point(inst.world_from_object, glm::dvec3(m.positions[m.indices[3 * t + k]]));
        c.push_back({p.x, p.y, p.z});
      }
      const int first = static_cast<int>(std::min_element(c.begin(), c.end()) - c.begin());
      std::vector<double> key;
      for (int k = 0; k < 3; ++k) key.insert(key.end(), c[(first + k) % 3].begin(), c[(first + k) % 3].end());
      out.insert(key);
    }
  }
  return out;
}

// Renders both scenes from the same view on the CPU reference: the share of
// pixels whose hit or miss agrees, and the largest relative depth difference
// over pixels both hit.
void compare_renders(const Scene& a, const Scene& b, double* agree, double* worst) {
  PipelineOptions o;
  o.backend = Backend::cpu;
  Pipeline ra(a, o), rb(b, o);
  CameraSpec view;
  view.eye = glm::dvec3(-17.5, 3.0, 0.5);
  view.look_at = glm::dvec3(10.0, 2.0, -1.0);
  const Camera cam = make_camera(view, 160, 90);
  const auto ha = ra.render(cam).hits, hb = rb.render(cam).hits;
  size_t same = 0;
  *worst = 0.0;
  for (size_t i = 0; i < ha.size(); ++i) {
    const bool hit_a = ha[i].instance != RF_INVALID, hit_b = hb[i].instance != RF_INVALID;
    same += hit_a == hit_b;
    if (hit_a && hit_b) *worst = std::max(*worst, std::fabs(double(ha[i].z) - hb[i].z) / ha[i].z);
  }
  *agree = double(same) / ha.size();
}

TEST(Compressed, FilesFromGltfpackAndDracoTranscoderShowTheSameScene) {
  if (!have_tool("gltfpack") || !have_tool("draco_transcoder"))
    GTEST_SKIP() << "gltfpack or draco_transcoder is not installed (tools/scripts/install-deps.sh installs both)";
  const std::string src = RAYFOLD_SOURCE_DIR "/scenes/atrium.glb";
  const Scene original = load_gltf(src);
  const std::filesystem::path dir = testing::temp_dir();
  struct Case {
    const char* name;
    std::string command;
    bool lossless;  // the same triangles, exactly
  };
  const std::string out = (dir / "packed").string();
  const Case cases[] = {
      {"draco, positions unquantized", "draco_transcoder -qp 0 -i " + src + " -o " + out + "_dq0.glb", true},
      {"draco, default quantization", "draco_transcoder -i " + src + " -o " + out + "_dq.glb", false},
      {"gltfpack -cc -noq", "gltfpack -cc -noq -i " + src + " -o " + out + "_mnoq.glb", false},
      {"gltfpack -cc (quantized)", "gltfpack -cc -i " + src + " -o " + out + "_mq.glb", false},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    ASSERT_EQ(std::system((c.command + " >/dev/null 2>&1").c_str()), 0) << c.command;
    const std::string file = c.command.substr(c.command.rfind(' ') + 1);
    const Scene packed = load_gltf(file);
    EXPECT_EQ(packed.triangle_count(), original.triangle_count());
    if (c.lossless) {
      EXPECT_TRUE(world_triangles(packed) == world_triangles(original));
    }
    double agree = 0.0, worst = 0.0;
    compare_renders(original, packed, &agree, &worst);
    // Quantization moves silhouettes by a fraction of a pixel.
    EXPECT_GE(agree, c.lossless ? 1.0 : 0.995) << agree;
    if (c.lossless) {
      EXPECT_LT(worst, 1e-6) << worst;
    }
  }
}

}  // namespace
}  // namespace rayfold::core
