// Optical flow between two views (kFlow, kFlowVisible) against flow
// computed here by hand: each hit's point from its ray and depth, projected
// through the other camera's pose and intrinsics; an animated node's
// motion; and occlusion by a quad in front, found by intersecting the
// segment with its plane.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "gltf_fixture.h"
#include "rayfold/rayfold.h"
#include "test_util.h"

namespace {

using rayfold::core::testing::GltfFile;

constexpr unsigned kFlowPlanes = rayfold::kFlow | rayfold::kFlowVisible | rayfold::kDepth | rayfold::kInstanceId;

// Quads facing +z: [-h, h]^2 at height z each, node names "q0", "q1", ...;
// with `moving`, node 0 is animated from x = 0 at t = 0 to x = 1 at t = 1.
std::string quads_file(const std::string& name, const std::vector<std::pair<double, double>>& quads,
                       bool moving = false) {
  GltfFile f;
  const std::vector<glm::vec3> p = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
  static const uint16_t kIdx[6] = {0, 1, 2, 0, 2, 3};
  const int pos = f.positions(p);
  f.j["meshes"] = {
      {{"primitives", {rayfold::core::testing::prim(pos, f.accessor(f.view(kIdx, 12), 5123, "SCALAR", 6))}}}};
  f.j["nodes"] = nlohmann::json::array();
  for (size_t i = 0; i < quads.size(); ++i)
    f.j["nodes"].push_back({{"mesh", 0},
                            {"name", "q" + std::to_string(i)},
                            {"translation", {0, 0, quads[i].second}},
                            {"scale", {quads[i].first, quads[i].first, 1}}});
  if (moving) {
    static const float kTimes[2] = {0, 1};
    const float z = static_cast<float>(quads[0].second);
    const float moves[6] = {0, 0, z, 1, 0, z};
    const int times = f.accessor(f.view(kTimes, 8), 5126, "SCALAR", 2);
    f.j["accessors"][times]["min"] = {0};
    f.j["accessors"][times]["max"] = {1};
    const int values = f.accessor(f.view(moves, 24), 5126, "VEC3", 2);
    nlohmann::json animation;
    animation["samplers"] = {{{"input", times}, {"output", values}, {"interpolation", "LINEAR"}}};
    animation["channels"] = nlohmann::json::array();
    animation["channels"].push_back({{"sampler", 0}, {"target", {{"node", 0}, {"path", "translation"}}}});
    f.j["animations"] = nlohmann::json::array({animation});
  }
  return f.write(name);
}

// Pixel coordinates (pixel centres at integers, +y down) of a world point
// in a perspective camera, from its public pose and intrinsics.
std::array<double, 2> by_hand(const rayfold::Camera& c, const std::array<double, 3>& w) {
  const rayfold::Matrix4 m = c.world_to_camera(rayfold::CameraConvention::opencv);
  double p[3];
  for (int r = 0; r < 3; ++r) p[r] = m[4 * r] * w[0] + m[4 * r + 1] * w[1] + m[4 * r + 2] * w[2] + m[4 * r + 3];
  const rayfold::Intrinsics k = c.intrinsics();
  return {k.fx * p[0] / p[2] + k.cx - 0.5, k.fy * p[1] / p[2] + k.cy - 0.5};
}

// The world point a pixel's ray meets at its depth.
std::array<double, 3> hit_point(const rayfold::Camera& c, const rayfold::GBuffer& g, int x, int y) {
  const rayfold::Vec3 o = c.ray_origin(x, y), d = c.ray_direction(x, y);
  const double t = g.depth[static_cast<size_t>(y) * g.width + x];
  return {o[0] + t * d[0], o[1] + t * d[1], o[2] + t * d[2]};
}

TEST(Flow, ToAnotherCameraIsTheProjectionByHand) {
  const rayfold::Scene scene = rayfold::Scene::load(quads_file("flow_cameras", {{2.0, 0.0}}));
  rayfold::Renderer renderer(scene);
  const rayfold::Camera a = rayfold::Camera::look_at({0.3, 0.2, 4}, {0, 0, 0}, {0, 1, 0}, 50, 64, 48);
  const rayfold::Camera b = rayfold::Camera::look_at({-0.8, 0.5, 3.5}, {0.1, 0, 0}, {0, 1, 0}, 40, 80, 60);
  // To itself: no motion, every surface seen.
  const rayfold::GBuffer self = renderer.render(a, rayfold::Fold::xy, kFlowPlanes, rayfold::FlowTo{a});
  size_t hits = 0;
  for (size_t i = 0; i < self.instance_id.size(); ++i) {
    if (self.instance_id[i] == rayfold::kMiss) {
      ASSERT_EQ(self.flow_visible[i], rayfold::kMiss);
      ASSERT_EQ(self.flow[2 * i], 0.0f);
      continue;
    }
    ++hits;
    ASSERT_LE(std::fabs(self.flow[2 * i]), 1e-3) << i;
    ASSERT_LE(std::fabs(self.flow[2 * i + 1]), 1e-3) << i;
    ASSERT_EQ(self.flow_visible[i], 1u) << i;
  }
  ASSERT_GT(hits, 1500u);
  const rayfold::GBuffer g = renderer.render(a, rayfold::Fold::xy, kFlowPlanes, rayfold::FlowTo{b});
  size_t inside = 0;
  for (int y = 0; y < g.height; ++y)
    for (int x = 0; x < g.width; ++x) {
      const size_t i = static_cast<size_t>(y) * g.width + x;
      if (g.instance_id[i] == rayfold::kMiss) continue;
      const std::array<double, 2> at = by_hand(b, hit_point(a, g, x, y));
      ASSERT_NEAR(g.flow[2 * i], at[0] - x, 2e-3) << "flow x at pixel " << x << ", " << y;
      ASSERT_NEAR(g.flow[2 * i + 1], at[1] - y, 2e-3) << "flow y at pixel " << x << ", " << y;
      const bool in_b = at[0] > -0.499 && at[0] < b.width() - 0.501 && at[1] > -0.499 && at[1] < b.height() - 0.501;
      const bool near_edge = std::fabs(at[0] + 0.5) < 1e-2 || std::fabs(at[0] - b.width() + 0.5) < 1e-2 ||
                             std::fabs(at[1] + 0.5) < 1e-2 || std::fabs(at[1] - b.height() + 0.5) < 1e-2;
      if (!near_edge) ASSERT_EQ(g.flow_visible[i], in_b ? 1u : 0u) << "pixel " << x << ", " << y;
      inside += in_b;
    }
  EXPECT_GT(inside, 500u);
  // Every fold and the CPU reference give the same bits.
  rayfold::RendererOptions cpu;
  cpu.backend = rayfold::Backend::cpu;
  rayfold::Renderer reference(scene, cpu);
  EXPECT_EQ(
      rayfold::count_differing_pixels(reference.render(a, rayfold::Fold::none, kFlowPlanes, rayfold::FlowTo{b}), g),
      0u);
}

TEST(Flow, AQuadInFrontHidesWhatItCoversFromTheOtherEye) {
  // The back quad [-1, 1]^2 at z = 0, a front one [-0.25, 0.25]^2 at z = 0.5.
  const rayfold::Scene scene = rayfold::Scene::load(quads_file("flow_occluded", {{1.0, 0.0}, {0.25, 0.5}}));
  rayfold::Renderer renderer(scene);
  const rayfold::Camera a = rayfold::Camera::look_at({0, 0, 3}, {0, 0, 0}, {0, 1, 0}, 45, 64, 64);
  const std::array<double, 3> eye = {0.9, 0.3, 3};
  const rayfold::Camera b = rayfold::Camera::look_at({eye[0], eye[1], eye[2]}, {0, 0, 0}, {0, 1, 0}, 60, 64, 64);
  const rayfold::GBuffer g = renderer.render(a, rayfold::Fold::none, kFlowPlanes, rayfold::FlowTo{b});
  size_t hidden = 0, seen = 0;
  for (int y = 0; y < g.height; ++y)
    for (int x = 0; x < g.width; ++x) {
      const size_t i = static_cast<size_t>(y) * g.width + x;
      if (g.instance_id[i] != 0) continue;  // the back quad's points
      const std::array<double, 3> p = hit_point(a, g, x, y);
      // Where the segment from b's eye to p crosses the front quad's plane.
      const double s = (eye[2] - 0.5) / (eye[2] - p[2]);
      const double qx = eye[0] + s * (p[0] - eye[0]), qy = eye[1] + s * (p[1] - eye[1]);
      if (std::fabs(std::fabs(qx) - 0.25) < 1e-3 || std::fabs(std::fabs(qy) - 0.25) < 1e-3) continue;
      const bool behind = std::fabs(qx) < 0.25 && std::fabs(qy) < 0.25;
      ASSERT_EQ(g.flow_visible[i], behind ? 0u : 1u) << "pixel " << x << ", " << y;
      (behind ? hidden : seen)++;
    }
  EXPECT_GT(hidden, 50u);
  EXPECT_GT(seen, 500u);
}

TEST(Flow, AListOfViewsFlowsFromEachToTheNext) {
  const rayfold::Scene scene = rayfold::Scene::load(quads_file("flow_list", {{1.0, 0.0}, {0.25, 0.5}}));
  rayfold::Renderer renderer(scene);
  std::vector<rayfold::Camera> views;
  for (int k = 0; k < 5; ++k)
    views.push_back(rayfold::Camera::look_at({0.3 * k - 0.6, 0.1 * k, 3}, {0, 0, 0}, {0, 1, 0}, 50, 48, 40));
  const unsigned planes = kFlowPlanes | rayfold::kShadingNormal;
  for (int align : {0, 1})
    for (rayfold::Fold fold : {rayfold::Fold::none, rayfold::Fold::xy}) {
      const std::vector<rayfold::GBuffer> got = renderer.render_views(views, fold, align, planes);
      ASSERT_EQ(got.size(), views.size());
      for (size_t k = 0; k + 1 < views.size(); ++k) {
        // Each view's planes are its render with the flow to the next view.
        const rayfold::GBuffer want = renderer.render(views[k], fold, planes, rayfold::FlowTo{views[k + 1]});
        EXPECT_EQ(got[k].channels, planes);
        EXPECT_EQ(rayfold::count_differing_pixels(got[k], want), 0u) << "view " << k << " align " << align;
      }
      // No view follows the last: NaN where it hits, flow_visible 0.
      const rayfold::GBuffer& last = got.back();
      size_t hits = 0;
      for (size_t p = 0; p < last.instance_id.size(); ++p) {
        const bool hit = last.instance_id[p] != rayfold::kMiss;
        hits += hit;
        ASSERT_EQ(std::isnan(last.flow[2 * p]) && std::isnan(last.flow[2 * p + 1]), hit) << "pixel " << p;
        ASSERT_EQ(last.flow_visible[p], hit ? 0u : rayfold::kMiss) << "pixel " << p;
      }
      EXPECT_GT(hits, 500u);
    }
  // Without the ids asked for, the flow still finds its triangles; they are
  // not handed back.
  const std::vector<rayfold::GBuffer> flow_only = renderer.render_views(views, rayfold::Fold::none, 0, rayfold::kFlow);
  EXPECT_TRUE(flow_only[0].instance_id.empty() && flow_only[0].uv.empty());
  EXPECT_EQ(flow_only[0].flow,
            renderer.render(views[0], rayfold::Fold::none, rayfold::kFlow, rayfold::FlowTo{views[1]}).flow);
}

TEST(Flow, AMovingNodeIsFollowedAcrossTimeAndThePoseIsPutBack) {
  // Node 0 moves by +1 in x from t = 0 to t = 1; seen straight on by an
  // orthographic camera whose pixels are 1/16 wide, its points move 16
  // pixels right.
  rayfold::Scene scene = rayfold::Scene::load(quads_file("flow_moving", {{0.5, 0.0}}, true));
  scene.set_time(0.0);
  rayfold::Renderer renderer(scene);
  const rayfold::Camera c = rayfold::Camera::orthographic({0.3, 0, 5}, {0.3, 0, 0}, {0, 1, 0}, 2.0, 64, 64);
  const rayfold::Matrix4 before = scene.transform(0);
  const rayfold::GBuffer g = renderer.render(c, rayfold::Fold::none, kFlowPlanes, rayfold::FlowTo{c, 1.0});
  EXPECT_EQ(scene.time(), 0.0);
  EXPECT_EQ(scene.transform(0), before) << "the pose is put back";
  size_t hits = 0;
  for (size_t i = 0; i < g.flow_visible.size(); ++i) {
    if (g.instance_id[i] == rayfold::kMiss) continue;
    ++hits;
    ASSERT_NEAR(g.flow[2 * i], 16.0, 1e-4) << i;
    ASSERT_NEAR(g.flow[2 * i + 1], 0.0, 1e-4) << i;
    ASSERT_EQ(g.flow_visible[i], 1u) << i;
  }
  EXPECT_EQ(hits, 256u);  // the quad is 1 wide: 16 x 16 pixels
  // Put back as it was, a move made by hand included; render_at poses one render alone.
  rayfold::Matrix4 moved = before;
  moved[3] += 0.25;
  scene.set_transform(0, moved);
  const rayfold::GBuffer by_hand =
      renderer.render(c, rayfold::Fold::none, rayfold::kFlow | rayfold::kInstanceId, rayfold::FlowTo{c, 1.0});
  EXPECT_EQ(scene.transform(0), moved);
  for (size_t i = 0; i < by_hand.instance_id.size(); ++i)
    if (by_hand.instance_id[i] != rayfold::kMiss) ASSERT_NEAR(by_hand.flow[2 * i], 12.0, 1e-4) << i;  // 0.75 of 1
  const rayfold::GBuffer at_one = renderer.render_at(1.0, c, rayfold::Fold::none, rayfold::kInstanceId);
  EXPECT_EQ(scene.transform(0), moved);
  EXPECT_EQ(scene.time(), 0.0);
  scene.set_transform(0, before);
  // The next render sees the scene as it was.
  const rayfold::GBuffer again = renderer.render(c, rayfold::Fold::none, rayfold::kInstanceId);
  EXPECT_EQ(again.instance_id, g.instance_id);
  EXPECT_NE(at_one.instance_id, g.instance_id) << "render_at(1) sees the node moved";
  // Seen by an orthographic camera facing it from behind its image plane, nothing is visible.
  const rayfold::Camera behind = rayfold::Camera::orthographic({0.3, 0, -5}, {0.3, 0, -10}, {0, 1, 0}, 2.0, 64, 64);
  const rayfold::GBuffer away = renderer.render(c, rayfold::Fold::none, kFlowPlanes, rayfold::FlowTo{behind});
  for (size_t i = 0; i < away.flow_visible.size(); ++i)
    if (away.instance_id[i] != rayfold::kMiss) {
      ASSERT_EQ(away.flow_visible[i], 0u) << i;
      ASSERT_TRUE(std::isnan(away.flow[2 * i])) << i;
    }
  // Flow is asked of a render with a view to flow to, and time of a file.
  EXPECT_THROW(renderer.render(c, rayfold::Fold::none, rayfold::kFlow), rayfold::InputError);
  rayfold::Scene made;
  made.add_instance(made.add_mesh(std::vector<float>{-1, -1, 0, 1, -1, 0, 0, 1, 0}, {0, 1, 2}), rayfold::kIdentity);
  rayfold::Renderer r(made);
  EXPECT_THROW(r.render(c, rayfold::Fold::none, rayfold::kFlow, rayfold::FlowTo{c, 1.0}), rayfold::InputError);
}

}  // namespace
