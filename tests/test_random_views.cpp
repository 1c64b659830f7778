// The benchmarks' random views (tools/fixtures/random_views.h): reproducible from the
// seed, drawn where the documented rules say, each seeing what its threshold
// asks, and the scene kind told apart on scenes whose answer is known.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "fixtures/random_views.h"
#include "test_util.h"

namespace rayfold::core {
namespace {

using testing::cpu_pipeline;
using testing::same_bits;

// A solid object, or a closed room seen from inside.
Scene box_scene(bool inward, const Xform& world_from_object = Xform(1.0)) {
  const Mesh m = testing::wound_box(inward);
  Scene s;
  s.meshes.push_back(m);
  Instance inst;
  inst.world_from_object = world_from_object;
  s.instances.push_back(inst);
  return s;
}

TEST(RandomViews, TellsRoomsFromObjects) {
  const Scene room = box_scene(true), solid = box_scene(false);
  EXPECT_EQ(classify_scene(room, *cpu_pipeline(room)), ViewKind::interior);
  EXPECT_EQ(classify_scene(solid, *cpu_pipeline(solid)), ViewKind::object);
}

TEST(RandomViews, TheSeedGivesTheViews) {
  const Scene s = box_scene(false, glm::translate(Xform(1.0), glm::dvec3(5.0, -2.0, 1.0)));
  auto cpu = cpu_pipeline(s);
  const RandomViews a = random_views(s, *cpu, 6, 7), b = random_views(s, *cpu, 6, 7), c = random_views(s, *cpu, 6, 8);
  ASSERT_EQ(a.cameras.size(), 6u);
  int differ = 0;
  for (size_t v = 0; v < a.cameras.size(); ++v) {
    EXPECT_TRUE(same_bits(a.cameras[v].eye, b.cameras[v].eye)) << "view " << v;
    EXPECT_TRUE(same_bits(a.cameras[v].look_at, b.cameras[v].look_at)) << "view " << v;
    EXPECT_EQ(a.cameras[v].vfov_degrees, b.cameras[v].vfov_degrees) << "view " << v;
    differ += !same_bits(a.cameras[v].eye, c.cameras[v].eye);
  }
  EXPECT_EQ(differ, 6) << "another seed must give other views";
}

// Orbits: the eye at 1.2 to 3 bounding-sphere radii from the centre, the
// field of view in range, and each view seeing at least a quarter of its
// pixels, counted again here on a render of the view.
TEST(RandomViews, ObjectsAreOrbitedAndSeen) {
  const Scene s = box_scene(false, glm::scale(Xform(1.0), glm::dvec3(3.0, 1.0, 0.5)));
  auto cpu = cpu_pipeline(s);
  const RandomViews rv = random_views(s, *cpu, 12, 3);
  EXPECT_EQ(rv.kind, ViewKind::object);
  EXPECT_EQ(rv.below_threshold, 0);
  const Aabb b = s.world_bounds();
  const glm::dvec3 centre = glm::dvec3(b.centre());
  const double radius = 0.5 * glm::length(glm::dvec3(b.extent()));
  for (size_t v = 0; v < rv.cameras.size(); ++v) {
    const CameraSpec& c = rv.cameras[v];
    const double d = glm::length(c.eye - centre) / radius;
    EXPECT_GE(d, 1.2 - 1e-9) << "view " << v;
    EXPECT_LE(d, 3.0 + 1e-9) << "view " << v;
    EXPECT_LE(glm::length(c.look_at - centre), 0.25 * radius * (1 + 1e-9)) << "view " << v;
    EXPECT_GE(c.vfov_degrees, 40.0);
    EXPECT_LT(c.vfov_degrees, 90.0);
    const RenderResult r = cpu->render(make_camera(c, 64, 36));
    size_t hits = 0;
    for (const rf_pixel_hit& h : r.hits) hits += h.instance != RF_INVALID;
    EXPECT_EQ(static_cast<double>(hits) / r.hits.size(), rv.hit_fraction[v]) << "view " << v;
    EXPECT_GE(rv.hit_fraction[v], 0.25) << "view " << v;
  }
}

TEST(RandomViews, InteriorEyesStayInside) {
  const Scene s = box_scene(true, glm::scale(Xform(1.0), glm::dvec3(10.0, 3.0, 6.0)));
  auto cpu = cpu_pipeline(s);
  const RandomViews rv = random_views(s, *cpu, 8, 11);
  EXPECT_EQ(rv.kind, ViewKind::interior);
  const Aabb b = s.world_bounds();
  for (size_t v = 0; v < rv.cameras.size(); ++v) {
    for (int a = 0; a < 3; ++a) {
      const double margin = 0.1 * (b.hi[a] - b.lo[a]);
      EXPECT_GE(rv.cameras[v].eye[a], b.lo[a] + margin) << "view " << v << " axis " << a;
      EXPECT_LE(rv.cameras[v].eye[a], b.hi[a] - margin) << "view " << v << " axis " << a;
    }
    EXPECT_EQ(rv.hit_fraction[v], 1.0) << "a closed room fills every view";
  }
}

// A scene that can never meet the interior thresholds (a solid seen from
// inside its own bounds sees back faces): the generator stops after its
// draws, keeps a view and says so.
TEST(RandomViews, GivesUpAndSaysSo) {
  const Scene s = box_scene(false);
  auto cpu = cpu_pipeline(s);
  const RandomViews rv = random_views(s, *cpu, 1, 5, ViewKind::interior);
  ASSERT_EQ(rv.cameras.size(), 1u);
  EXPECT_EQ(rv.below_threshold, 1);
  EXPECT_EQ(rv.redrawn, 200);
}

}  // namespace
}  // namespace rayfold::core
