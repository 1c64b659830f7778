// The scene generators: deterministic, within budget, and the bundled default
// scene is exactly its output (so the file in scenes/ cannot drift from the
// code that claims to make it); the G-buffer's test scene holds what it says
// (its channels are checked in tests/python/test_gbuffer_scene.py).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "fixtures/gbuffer_scene.h"
#include "fixtures/gltf_writer.h"
#include "fixtures/scene_gen.h"
#include "scene/attributes.h"
#include "scene/gltf_loader.h"

namespace rayfold::core {
namespace {

std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), {});
}

TEST(SceneGen, DefaultSceneMeetsItsBrief) {
  const Scene s = generate_atrium(GenOptions{});
  EXPECT_GE(s.instances.size(), 200u);
  EXPECT_GE(s.triangle_count(), 100000u);
  EXPECT_LE(s.triangle_count(), GenOptions{}.triangle_budget);
  // Very different sizes: the largest instance box dwarfs the smallest.
  double smallest = INFINITY, largest = 0.0;
  for (const Instance& i : s.instances) {
    const Aabb b = transform_bounds_conservative(i.world_from_object, s.mesh_bounds(i.mesh));
    const double d = glm::length(glm::dvec3(b.extent()));
    smallest = std::min(smallest, d);
    largest = std::max(largest, d);
  }
  EXPECT_GT(largest / smallest, 50.0);
}

TEST(SceneGen, SameOptionsSameScene) {
  GenOptions o;
  o.seed = 42;
  o.objects = 50;
  o.triangle_budget = 10000;
  const Scene a = generate_atrium(o), b = generate_atrium(o);
  ASSERT_EQ(a.instances.size(), b.instances.size());
  EXPECT_EQ(a.instances.size(), 50u);
  for (size_t i = 0; i < a.instances.size(); ++i)
    EXPECT_TRUE(a.instances[i].world_from_object == b.instances[i].world_from_object);
  o.seed = 43;
  const Scene c = generate_atrium(o);
  bool differs = false;
  for (size_t i = 0; i < a.instances.size(); ++i)
    differs |= !(a.instances[i].world_from_object == c.instances[i].world_from_object);
  EXPECT_TRUE(differs);
}

TEST(SceneGen, TinyObjectCounts) {
  for (int n : {1, 2, 5, 9}) {
    GenOptions o;
    o.objects = n;
    o.triangle_budget = 3000;
    const Scene s = generate_atrium(o);
    EXPECT_EQ(s.instances.size(), static_cast<size_t>(n));
    EXPECT_LE(s.triangle_count(), 3000u);
    EXPECT_GT(s.triangle_count(), 0u);
  }
}

TEST(SceneGen, BundledSceneIsTheGeneratorsOutput) {
  const std::string bundled = std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb";
  const std::string fresh =
      (std::filesystem::temp_directory_path() / ("atrium_" + std::to_string(::getpid()) + ".glb")).string();
  write_glb(generate_atrium(GenOptions{}), fresh);
  EXPECT_TRUE(read_bytes(bundled) == read_bytes(fresh))
      << "scenes/atrium.glb differs from rayfold-gen-scene's output; regenerate it with\n"
      << "  build/rayfold-gen-scene -o scenes/atrium.glb";
  std::filesystem::remove(fresh);
}

TEST(SceneGen, GbufferSceneHoldsEveryFeatureItNamesAndIsTheSameForASeed) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path();
  const std::string a = (dir / ("gbuffer_a_" + std::to_string(::getpid()) + ".glb")).string();
  const std::string b = (dir / ("gbuffer_b_" + std::to_string(::getpid()) + ".glb")).string();
  const std::string c = (dir / ("gbuffer_c_" + std::to_string(::getpid()) + ".glb")).string();
  write_gbuffer_scene(a, 1);
  write_gbuffer_scene(b, 1);
  write_gbuffer_scene(c, 2);
  EXPECT_TRUE(read_bytes(a) == read_bytes(b)) << "the same seed must give the same bytes";
  EXPECT_FALSE(read_bytes(a) == read_bytes(c)) << "another seed, other texels";
  LoadOptions o;
  o.attributes = kAttributeNormal | kAttributeTangent | kAttributeTexcoord0 | kAttributeColor0 | kAttributeMaterial |
                 kAttributeMaterialData | kAttributeNormalTexture | kAttributeLabel;
  o.label_key = "category";
  const Scene s = load_gltf(a, nullptr, o);
  ASSERT_EQ(s.instances.size(), 4u);  // the panel twice, the box, the strip
  ASSERT_EQ(s.meshes.size(), 3u);
  EXPECT_EQ(s.materials.size(), 3u);
  EXPECT_EQ(s.images.size(), 3u);
  const MeshAttributes& panel = s.meshes[s.instances[0].mesh].attributes;
  EXPECT_EQ(panel.present & (kAttributeNormal | kAttributeTangent | kAttributeTexcoord0 | kAttributeColor0),
            kAttributeNormal | kAttributeTangent | kAttributeTexcoord0 | kAttributeColor0);
  const Material& painted = s.materials[0];
  EXPECT_GE(painted.base_color.image, 0);
  EXPECT_GE(painted.metallic_roughness.image, 0);
  EXPECT_GE(painted.normal.image, 0);
  EXPECT_GE(painted.emissive.image, 0);
  EXPECT_LT(glm::determinant(glm::dmat3(s.instances[1].world_from_object)), 0.0) << "the mirrored panel";
  EXPECT_EQ(s.labels, (std::vector<std::string>{"", "panel", "box"}));
  // Animated: the box moves and the skinned strip bends between 0 and 2 s.
  GltfFile file(a, o);
  EXPECT_TRUE(file.animated());
  EXPECT_EQ(file.animation_end(), 2.0);
  const Scene start = file.scene_at(0.0), end = file.scene_at(2.0);
  EXPECT_NE(start.instances[2].world_from_object, end.instances[2].world_from_object);
  EXPECT_NE(start.meshes[s.instances[3].mesh].positions, end.meshes[s.instances[3].mesh].positions);
  for (const std::string& p : {a, b, c}) std::filesystem::remove(p);
}

}  // namespace
}  // namespace rayfold::core
