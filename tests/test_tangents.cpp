// Tangents and normal maps: MikkTSpace's rule against the analytic tangent
// of a cylinder and a mirrored UV seam; the tangent and mapped_normal
// channels of a normal-mapped quad against values computed here by hand,
// the same quad with the file's TANGENT, rotated and mirrored by its node
// (the same geometry written other ways); and every backend and fold.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include <glm/geometric.hpp>

#include "api_fixture.h"
#include "gltf_fixture.h"
#include "rayfold/rayfold.h"
#include "scene/tangents.h"
#include "test_util.h"
#include "texture_fixture.h"

namespace {

using rayfold::core::mikktspace_tangents;
using rayfold::core::testing::GltfFile;
using rayfold::core::testing::png;
using rayfold::core::testing::Texels;

constexpr double kPi = 3.14159265358979323846;

// A cylinder of radius 1 around z, z in [0, 1], `segments` around; u the
// angle / 2 pi, v = 1 - z (glTF's v points down); the seam's vertices
// twice (u = 0 and u = 1). Indexed, or each corner its own vertex.
struct Cylinder {
  std::vector<glm::vec3> positions, normals;
  std::vector<glm::vec2> texcoords;
  std::vector<uint32_t> indices;
  Cylinder(int segments, bool indexed) {
    std::vector<glm::vec3> p, n;
    std::vector<glm::vec2> t;
    for (int i = 0; i <= segments; ++i) {
      const double a = 2.0 * kPi * i / segments;
      for (int z = 0; z < 2; ++z) {
        p.emplace_back(std::cos(a), std::sin(a), z);
        n.emplace_back(std::cos(a), std::sin(a), 0.0);
        t.emplace_back(static_cast<float>(i) / segments, 1.0f - z);
      }
    }
    std::vector<uint32_t> idx;
    for (int i = 0; i < segments; ++i) {
      const uint32_t a = 2 * i, b = 2 * i + 2;  // bottom corners; +1 the top ones
      for (uint32_t k : {a, b, b + 1, a, b + 1, a + 1}) idx.push_back(k);
    }
    if (indexed) {
      positions = p, normals = n, texcoords = t, indices = idx;
      return;
    }
    for (uint32_t k : idx) {
      indices.push_back(static_cast<uint32_t>(positions.size()));
      positions.push_back(p[k]), normals.push_back(n[k]), texcoords.push_back(t[k]);
    }
  }
  std::vector<glm::vec4> tangents() const {
    return mikktspace_tangents(positions.data(), normals.data(), texcoords.data(), indices.data(), indices.size() / 3);
  }
};

TEST(Tangents, MikkTSpaceOnACylinderIsTheDirectionOfU) {
  const int segments = 24;
  const Cylinder c(segments, true);
  const std::vector<glm::vec4> got = c.tangents();
  ASSERT_EQ(got.size(), c.indices.size());
  for (size_t k = 0; k < got.size(); ++k) {
    const glm::vec3 p = c.positions[c.indices[k]];
    const double a = std::atan2(p.y, p.x);
    const glm::dvec3 want(-std::sin(a), std::cos(a), 0.0);
    // Away from the seam both triangles beside a vertex are summed: their
    // chords' mean is the circle's tangent; at the seam (split by u) one
    // chord, half a segment off.
    const bool seam = c.texcoords[c.indices[k]].x == 0.0f || c.texcoords[c.indices[k]].x == 1.0f;
    const double tolerance = seam ? std::sin(kPi / segments) + 1e-6 : 1e-6;
    EXPECT_NEAR(glm::length(glm::dvec3(glm::vec3(got[k])) - want), 0.0, tolerance)
        << "corner " << k << " at angle " << a << ": got (" << got[k].x << ", " << got[k].y << ", " << got[k].z << ")";
    // u around z, v up z: bitangent = w cross(n, t) = +z, so w = +1.
    EXPECT_EQ(got[k].w, 1.0f) << "corner " << k;
  }
  // Written with every corner its own vertex, the same tangents: the rule
  // welds vertices equal in position, normal and texture coordinates.
  const std::vector<glm::vec4> unindexed = Cylinder(segments, false).tangents();
  ASSERT_EQ(unindexed.size(), got.size());
  for (size_t k = 0; k < got.size(); ++k)
    EXPECT_NEAR(glm::length(glm::vec3(unindexed[k]) - glm::vec3(got[k])), 0.0f, 1e-6f) << "corner " << k;
}

TEST(Tangents, AMirroredUvSeamGivesEachSideItsOwn) {
  // The quad [-1, 1] x [0, 1] facing +z, u = |x|: its middle vertices
  // (u = 0) are shared by both halves, whose uv winds opposite ways.
  const std::vector<glm::vec3> p = {{-1, 0, 0}, {0, 0, 0}, {1, 0, 0}, {-1, 1, 0}, {0, 1, 0}, {1, 1, 0}};
  const std::vector<glm::vec3> n(6, glm::vec3(0, 0, 1));
  const std::vector<glm::vec2> t = {{1, 1}, {0, 1}, {1, 1}, {1, 0}, {0, 0}, {1, 0}};
  const std::vector<uint32_t> idx = {0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4};
  const std::vector<glm::vec4> got = mikktspace_tangents(p.data(), n.data(), t.data(), idx.data(), 4);
  for (size_t k = 0; k < got.size(); ++k) {
    const bool left = k < 6;
    // Left: u grows toward -x, and bitangent w cross(z, -x) = -w y must be
    // +y (v up): w = -1. Right: +x, w = +1.
    EXPECT_EQ(got[k], glm::vec4(left ? -1.0f : 1.0f, 0.0f, 0.0f, left ? -1.0f : 1.0f)) << "corner " << k;
  }
}

TEST(Tangents, TrianglesAroundAVertexWeighByTheirAngleThere) {
  // Two triangles at the origin o, facing +z, sharing the edge to q = (1,
  // 1): A = (o, (1, 0), q), 45 degrees at o, mapped u = x, v up = y
  // (dP/du = +x); B = (o, q, r = (-1, 1)), 90 degrees at o, dP/du = (1.5,
  // 0.5) and dP/dv = (-0.5, 0.5), the same orientation, q at uv (1, 1) in
  // both. With glTF's v down, v is stored negated.
  const std::vector<glm::vec3> p = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {-1, 1, 0}};
  const std::vector<glm::vec3> n(4, glm::vec3(0, 0, 1));
  const std::vector<glm::vec2> t = {{0, 0}, {1, 0}, {1, -1}, {0, -2}};
  const std::vector<uint32_t> idx = {0, 1, 2, 0, 2, 3};
  const std::vector<glm::vec4> got = mikktspace_tangents(p.data(), n.data(), t.data(), idx.data(), 2);
  const glm::dvec3 want =
      glm::normalize(kPi / 4 * glm::dvec3(1, 0, 0) + kPi / 2 * glm::dvec3(3, 1, 0) / std::sqrt(10.0));
  for (size_t k : {size_t{0}, size_t{3}})
    EXPECT_NEAR(glm::length(glm::dvec3(glm::vec3(got[k])) - want), 0.0, 1e-6)
        << "corner " << k << " at o: got (" << got[k].x << ", " << got[k].y << ", " << got[k].z << "), want (" << want.x
        << ", " << want.y << ", " << want.z << ")";
}

// One texel's normal map value (2 byte / 255 - 1), as the resolve reads it.
double unpacked(uint8_t byte) { return 2.0 * (byte / 255.0) - 1.0; }

// The quad [-1, 1]^2 at z = 0 facing +z with NORMAL +z, TEXCOORD_0 (0, 0)
// at its top left, a constant normal texture; optionally the file's
// TANGENT, and a node transform.
struct NormalMappedQuad {
  GltfFile f;
  static constexpr uint8_t kTexel[4] = {204, 128, 230, 255};
  NormalMappedQuad(double scale, const float* tangent, const nlohmann::json& node_matrix, bool texcoords = true) {
    const std::vector<glm::vec3> p = {{-1, 1, 0}, {1, 1, 0}, {1, -1, 0}, {-1, -1, 0}};
    static const float kNormal[12] = {0, 0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1};
    static const float kUv[8] = {0, 0, 1, 0, 1, 1, 0, 1};
    static const uint16_t kIdx[6] = {0, 3, 2, 0, 2, 1};
    nlohmann::json prim = rayfold::core::testing::prim(f.positions(p), f.accessor(f.view(kIdx, 12), 5123, "SCALAR", 6));
    prim["attributes"]["NORMAL"] = f.accessor(f.view(kNormal, 48), 5126, "VEC3", 4);
    if (texcoords) prim["attributes"]["TEXCOORD_0"] = f.accessor(f.view(kUv, 32), 5126, "VEC2", 4);
    if (tangent) {
      static float four[16];
      for (int k = 0; k < 16; ++k) four[k] = tangent[k % 4];
      prim["attributes"]["TANGENT"] = f.accessor(f.view(four, 64), 5126, "VEC4", 4);
    }
    prim["material"] = 0;
    Texels texels{4, 4, {}};
    for (int k = 0; k < 16; ++k) texels.rgba.insert(texels.rgba.end(), kTexel, kTexel + 4);
    const std::vector<uint8_t> bytes = png(texels);
    f.j["images"] = {{{"bufferView", f.view(bytes.data(), bytes.size())}, {"mimeType", "image/png"}}};
    f.j["textures"] = {{{"source", 0}}};
    f.j["materials"] = {{{"normalTexture", {{"index", 0}, {"scale", scale}}}}};
    f.j["meshes"] = {{{"name", "quad"}, {"primitives", {prim}}}};
    f.j["nodes"] = {{{"mesh", 0}}};
    if (!node_matrix.is_null()) f.j["nodes"][0]["matrix"] = node_matrix;
  }
};

// The quad's mapped normal in its own frame (T = +x, B = +y, N = +z).
glm::dvec3 mapped_in_frame(double scale) {
  const uint8_t* t = NormalMappedQuad::kTexel;
  return glm::normalize(glm::dvec3(unpacked(t[0]) * scale, unpacked(t[1]) * scale, unpacked(t[2])));
}

struct FramePlanes {
  rayfold::GBuffer g;
  size_t hits = 0;
};

FramePlanes render_frame(const std::string& path, std::vector<std::string>* warnings = nullptr) {
  const rayfold::Scene scene = rayfold::Scene::load(path);
  rayfold::Renderer renderer(scene);
  const rayfold::Camera camera = rayfold::Camera::orthographic({0.1, 0.2, 5}, {0.1, 0.2, 0}, {0, 1, 0}, 1.5, 16, 16);
  FramePlanes out{
      renderer.render(camera, rayfold::Fold::none, rayfold::kTangent | rayfold::kMappedNormal | rayfold::kInstanceId)};
  for (uint32_t id : out.g.instance_id) out.hits += id != rayfold::kMiss;
  if (warnings) *warnings = scene.warnings();
  return out;
}

// Every hit's tangent and mapped normal equal to the given ones (float
// rounding of double values: 2 ulps).
void expect_frame(const FramePlanes& f, const glm::dvec4& tangent, const glm::dvec3& mapped, const char* what) {
  ASSERT_GT(f.hits, 40u) << what;
  for (size_t p = 0; p < f.g.instance_id.size(); ++p) {
    if (f.g.instance_id[p] == rayfold::kMiss) continue;
    for (int k = 0; k < 4; ++k)
      ASSERT_NEAR(f.g.tangent[4 * p + k], tangent[k], 2e-7) << what << ": tangent[" << k << "] at pixel " << p;
    for (int k = 0; k < 3; ++k)
      ASSERT_NEAR(f.g.mapped_normal[3 * p + k], mapped[k], 2e-7)
          << what << ": mapped_normal[" << k << "] at pixel " << p;
  }
}

TEST(Tangents, ANormalMapTiltsTheNormalInTheTangentFrame) {
  const double scale = 0.5;
  const glm::dvec3 m = mapped_in_frame(scale);
  // MikkTSpace's frame of a quad mapped u right, v down: T = +x, w = +1.
  expect_frame(render_frame(NormalMappedQuad(scale, nullptr, nullptr).f.write("normal_map_generated")), {1, 0, 0, 1}, m,
               "generated tangents");
  // The file's TANGENT giving that frame: the same planes.
  const float tangent[4] = {1, 0, 0, 1};
  expect_frame(render_frame(NormalMappedQuad(scale, tangent, nullptr).f.write("normal_map_file")), {1, 0, 0, 1}, m,
               "the file's tangents");
  // A TANGENT of the other handedness flips the bitangent: y negated.
  const float flipped[4] = {1, 0, 0, -1};
  expect_frame(render_frame(NormalMappedQuad(scale, flipped, nullptr).f.write("normal_map_flipped")), {1, 0, 0, -1},
               {m.x, -m.y, m.z}, "the file's tangents, w = -1");
  // Turned a quarter about z by its node: T = +y, the tilt turned with it.
  const nlohmann::json quarter = {0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  expect_frame(render_frame(NormalMappedQuad(scale, nullptr, quarter).f.write("normal_map_turned")), {0, 1, 0, 1},
               {-m.y, m.x, m.z}, "turned a quarter");
  // Mirrored in x by its node: the tangent mirrored, w flipped, and the
  // mapped normal the mirror image of the unmirrored one.
  const nlohmann::json mirror = {-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  expect_frame(render_frame(NormalMappedQuad(scale, nullptr, mirror).f.write("normal_map_mirrored")), {-1, 0, 0, -1},
               {-m.x, m.y, m.z}, "mirrored");
}

TEST(Tangents, AMeshWithoutTextureCoordinatesKeepsItsShadingNormal) {
  std::vector<std::string> warnings;
  const FramePlanes f =
      render_frame(NormalMappedQuad(1.0, nullptr, nullptr, false).f.write("normal_map_no_uv"), &warnings);
  // Duff et al.'s perpendicular of +z is +x; the normal map is not applied.
  expect_frame(f, {1, 0, 0, 1}, {0, 0, 1}, "no texture coordinates");
  bool named = false;
  for (const std::string& w : warnings)
    named |= w.find("mesh 0 ('quad')") != std::string::npos && w.find("TANGENT") != std::string::npos;
  EXPECT_TRUE(named) << "no warning names the mesh and its tangents: " << ::testing::PrintToString(warnings);
}

TEST(Tangents, EveryBackendAndFoldGivesTheReferencesBits) {
  // A cylinder's tangents vary across it, seen in perspective.
  GltfFile f;
  const Cylinder c(12, true);
  std::vector<uint16_t> idx(c.indices.begin(), c.indices.end());
  nlohmann::json prim = rayfold::core::testing::prim(
      f.positions(c.positions), f.accessor(f.view(idx.data(), idx.size() * 2), 5123, "SCALAR", idx.size()));
  prim["attributes"]["NORMAL"] =
      f.accessor(f.view(c.normals.data(), c.normals.size() * 12), 5126, "VEC3", c.normals.size());
  prim["attributes"]["TEXCOORD_0"] =
      f.accessor(f.view(c.texcoords.data(), c.texcoords.size() * 8), 5126, "VEC2", c.texcoords.size());
  prim["material"] = 0;
  const std::vector<uint8_t> bytes = png(rayfold::core::testing::pattern(16, 16, 3));
  f.j["images"] = {{{"bufferView", f.view(bytes.data(), bytes.size())}, {"mimeType", "image/png"}}};
  f.j["textures"] = {{{"source", 0}}};
  f.j["materials"] = {{{"normalTexture", {{"index", 0}}}}};
  f.j["meshes"] = {{{"primitives", {prim}}}};
  f.j["nodes"] = {{{"mesh", 0}}};
  const rayfold::Scene scene = rayfold::Scene::load(f.write("tangent_bits"));
  const rayfold::Camera camera = rayfold::Camera::look_at({2.5, -3.0, 1.5}, {0, 0, 0.5}, {0, 0, 1}, 50.0, 48, 40);
  const rayfold::GBuffer want = rayfold::testing::same_bits_on_every_backend_and_fold(
      scene, camera, rayfold::kTangent | rayfold::kMappedNormal | rayfold::kInstanceId);
  size_t hits = 0;
  for (size_t p = 0; p < want.instance_id.size(); ++p) hits += want.instance_id[p] != rayfold::kMiss;
  EXPECT_GT(hits, 300u);
}

}  // namespace
