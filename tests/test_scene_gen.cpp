// The scene generator: deterministic, within budget, and the bundled default
// scene is exactly its output (so the file in scenes/ cannot drift from the
// code that claims to make it).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "fixtures/gltf_writer.h"
#include "fixtures/scene_gen.h"
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

}  // namespace
}  // namespace rayfold::core
