// The view chosen for a scene without a camera (pipeline/auto_frame.h): an
// object whole from outside, as before; a room from inside, along its length,
// and off the centre when the centre is inside something solid.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "pipeline/auto_frame.h"
#include "pipeline/pipeline.h"
#include "test_util.h"

namespace rayfold::core {
namespace {

using testing::cpu_pipeline;
using testing::same_bits;
using testing::wound_box;

Scene scene_of(const std::vector<Mesh>& meshes) {
  Scene s;
  for (const Mesh& m : meshes) {
    s.meshes.push_back(m);
    Instance inst;
    inst.mesh = static_cast<uint32_t>(s.meshes.size() - 1);
    s.instances.push_back(inst);
  }
  return s;
}

glm::dvec3 centre_of(const Scene& s) {
  const Aabb b = s.world_bounds();
  return 0.5 * (glm::dvec3(b.lo) + glm::dvec3(b.hi));
}

TEST(AutoFrame, AnObjectIsFramedWholeFromOutsideAsBefore) {
  const Scene s = scene_of({wound_box(false, {2.0f, 1.0f, 0.5f})});
  auto cpu = cpu_pipeline(s);
  const AutoFrame f = auto_frame(s, *cpu);
  EXPECT_EQ(f.kind, ViewKind::object);
  const CameraSpec want = frame_bounds(s.world_bounds());
  EXPECT_TRUE(same_bits(f.spec.eye, want.eye));
  EXPECT_TRUE(same_bits(f.spec.look_at, want.look_at));
  EXPECT_EQ(f.spec.vfov_degrees, want.vfov_degrees);
}

// A hall five times longer (x) than wide: from its centre, looking along x,
// every pixel sees a front face. Looking across it (z) would see the same
// walls nearer.
TEST(AutoFrame, ARoomIsSeenFromInsideAlongItsLength) {
  const Scene s = scene_of({wound_box(true, {5.0f, 1.0f, 1.0f})});
  auto cpu = cpu_pipeline(s);
  const AutoFrame f = auto_frame(s, *cpu);
  ASSERT_EQ(f.kind, ViewKind::interior);
  EXPECT_TRUE(same_bits(f.spec.eye, centre_of(s))) << f.spec.eye.x << " " << f.spec.eye.y << " " << f.spec.eye.z;
  const glm::dvec3 d = f.spec.look_at - f.spec.eye;
  EXPECT_GT(std::fabs(d.x), 0.99 * glm::length(d)) << "looks along " << d.x << " " << d.y << " " << d.z;
  EXPECT_EQ(d.y, 0.0);
  const Probe p = probe(*cpu, f.spec, 64, 36);
  EXPECT_EQ(p.hit_fraction, 1.0);
  EXPECT_EQ(p.front_fraction, 1.0);
  CameraSpec across = f.spec;
  across.look_at = across.eye + glm::dvec3(0.0, 0.0, 1.0);
  EXPECT_GT(p.median_front_depth, 1.5 * probe(*cpu, across, 64, 36).median_front_depth);
}

// A solid pillar around the hall's centre: the centre sees only the pillar's
// back faces, so the eye moves to an octant's centre, outside the pillar,
// and the view sees front faces.
TEST(AutoFrame, AnEyeInsideSomethingSolidMovesOut) {
  const Scene s = scene_of({wound_box(true, {4.0f, 1.0f, 4.0f}), wound_box(false, {0.5f, 1.0f, 0.5f})});
  auto cpu = cpu_pipeline(s);
  const AutoFrame f = auto_frame(s, *cpu);
  ASSERT_EQ(f.kind, ViewKind::interior);
  const glm::dvec3 off = f.spec.eye - centre_of(s);
  EXPECT_TRUE(std::fabs(off.x) > 0.5 || std::fabs(off.z) > 0.5)
      << "eye " << f.spec.eye.x << " " << f.spec.eye.y << " " << f.spec.eye.z;
  const Probe p = probe(*cpu, f.spec, 64, 36);
  EXPECT_GT(p.hit_fraction, 0.99);
  EXPECT_GT(p.front_fraction, 0.99);
}

}  // namespace
}  // namespace rayfold::core
