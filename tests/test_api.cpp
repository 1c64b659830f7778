// The public API (rayfold/rayfold.h) against the core it wraps: scenes built
// in memory against the same geometry traced by brute force, cameras given
// as matrices and intrinsics against the same view given by look-at, moved
// instances against a scene built with them in place, and its errors.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "api/scene_state.h"
#include "bvh/scene_file.h"
#include "opencl/cl_device.h"
#include "rayfold/rayfold.h"
#include "test_util.h"

namespace rayfold {
namespace {

using core::testing::compare_hits;
// Ray queries fill the channels asked for, each the full query's bits (t
// under kDepth); the others stay empty, and no channel or an unknown bit is
// an error. Without kNormal the normal is not computed, the rest unchanged,
// on each backend and kernel, for rays in lanes (one origin) and one by one.
TEST(Api, RayQueriesFillOnlyTheChannelsAskedFor) {
  const Scene scene = Scene::load(RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  const Camera cam = scene.default_camera(48, 30);
  std::vector<float> o, d, scattered;
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 48; ++x) {
      const Vec3 e = cam.ray_origin(x, y), v = cam.ray_direction(x, y);
      o.insert(o.end(), {float(e[0]), float(e[1]), float(e[2])});
      d.insert(d.end(), {float(v[0]), float(v[1]), float(v[2])});
      // The same rays from points spread along them: not one origin.
      const float back = static_cast<float>((x * 7 + y * 3) % 5) * 0.1f;
      scattered.insert(scattered.end(), {float(e[0] - back * v[0]), float(e[1] - back * v[1]), float(e[2] - back * v[2])});
    }
  const size_t n = o.size() / 3;
  for (auto [backend, kernel] : {std::pair{Backend::cpu, Kernel::automatic}, std::pair{Backend::opencl, Kernel::tile},
                                 std::pair{Backend::opencl, Kernel::single}}) {
    RendererOptions opt;
    opt.backend = backend;
    opt.kernel = kernel;
    Renderer r(scene, opt);
    for (const std::vector<float>* origins : {&o, &scattered}) {
      const std::string what = "backend " + std::to_string(int(backend)) + " kernel " + std::to_string(int(kernel)) +
                               (origins == &o ? ", one origin" : ", scattered");
      const RayHits all = r.intersect(origins->data(), d.data(), n);
      EXPECT_EQ(all.channels, kAllChannels);
      size_t hits = 0;
      for (uint32_t id : all.instance_id) hits += id != kMiss;
      EXPECT_GT(hits, n / 4) << what;
      const RayHits some = r.intersect(origins->data(), d.data(), n, 0.0f, INFINITY, 0, kDepth | kInstanceId);
      EXPECT_EQ(some.channels, kDepth | kInstanceId);
      ASSERT_EQ(some.t.size(), n) << what;
      EXPECT_EQ(std::memcmp(some.t.data(), all.t.data(), n * sizeof(float)), 0) << what;
      EXPECT_EQ(some.instance_id, all.instance_id) << what;
      EXPECT_TRUE(some.normal.empty() && some.uv.empty() && some.primitive_id.empty()) << what;
      const RayHits no_normal =
          r.intersect(origins->data(), d.data(), n, 0.0f, INFINITY, 0, kAllChannels & ~static_cast<unsigned>(kNormal));
      EXPECT_TRUE(no_normal.normal.empty()) << what;
      ASSERT_EQ(no_normal.uv.size(), 2 * n) << what;
      EXPECT_EQ(std::memcmp(no_normal.uv.data(), all.uv.data(), 2 * n * sizeof(float)), 0) << what;
      EXPECT_EQ(no_normal.primitive_id, all.primitive_id) << what;
      EXPECT_THROW(r.intersect(origins->data(), d.data(), n, 0.0f, INFINITY, 0, 0u), InputError);
      EXPECT_THROW(r.intersect(origins->data(), d.data(), n, 0.0f, INFINITY, 0, 64u), InputError);
    }
  }
}

// A core transform as the public API's row-major matrix.
using core::to_matrix;

// A core camera spec as a public look-at camera of w x h pixels.
Camera to_camera(const core::CameraSpec& spec, int w, int h) {
  return Camera::look_at({spec.eye.x, spec.eye.y, spec.eye.z}, {spec.look_at.x, spec.look_at.y, spec.look_at.z},
                         {spec.up.x, spec.up.y, spec.up.z}, spec.vfov_degrees, w, h);
}

// The core scene rebuilt through the public API, mesh for mesh and instance
// for instance.
Scene to_public(const core::Scene& s) {
  Scene out;
  for (const core::Mesh& m : s.meshes) {
    std::vector<float> p;
    for (const glm::vec3& v : m.positions) p.insert(p.end(), {v.x, v.y, v.z});
    out.add_mesh(p, m.indices, m.name);
  }
  for (const core::Instance& i : s.instances) out.add_instance(i.mesh, to_matrix(i.world_from_object), i.name);
  return out;
}

// The G-buffer's planes back in the device's pixel layout.
std::vector<rf_pixel_hit> to_hits(const GBuffer& g) {
  std::vector<rf_pixel_hit> h(g.depth.size());
  for (size_t i = 0; i < h.size(); ++i)
    h[i] = rf_pixel_hit{g.depth[i],  g.normal[3 * i], g.normal[3 * i + 1], g.normal[3 * i + 2],
                        g.uv[2 * i], g.uv[2 * i + 1], g.instance_id[i],    g.primitive_id[i]};
  return h;
}

std::vector<rf_pixel_hit> brute(const core::Scene& s, const Camera& camera) {
  const core::SceneData data = core::prepare_scene(s);
  return core::testing::brute_force(s, data, camera.core());
}

const Fold kFolds[] = {Fold::none, Fold::y, Fold::x, Fold::xy};

// A scene without a camera gets the view `rayfold render` chooses: a hall
// from inside, looking along it, every pixel a front face.
TEST(Api, TheDefaultCameraOfARoomIsInside) {
  core::Scene hall;
  hall.meshes.push_back(core::testing::wound_box(true, glm::vec3(5.0f, 1.0f, 1.0f)));
  hall.instances.push_back(core::Instance{});
  const Scene scene = to_public(hall);
  const Camera cam = scene.default_camera(32, 18);
  EXPECT_EQ(cam.eye(), (Vec3{0.0, 0.0, 0.0}));
  const GBuffer g = Renderer(scene, {Backend::cpu}).render(cam);
  EXPECT_EQ(g.hits, size_t{32 * 18});
  const float centre = g.depth[9 * 32 + 16];
  EXPECT_GT(centre, 4.9f) << "the centre pixel sees no end wall: not looking along the hall";
}

TEST(Api, InMemorySceneMatchesBruteForceInEveryBackendKernelAndFold) {
  core::testing::Rng rng(7);
  const core::Scene soup = core::testing::random_scene(rng, 3, 7, 40);
  const Scene scene = to_public(soup);
  ASSERT_EQ(scene.instance_count(), soup.instances.size());
  for (int view = 0; view < 3; ++view) {
    const core::CameraSpec spec = core::testing::random_camera(rng, soup.world_bounds());
    const Camera camera = to_camera(spec, 37, 23);
    const std::vector<rf_pixel_hit> expected = brute(soup, camera);
    for (Backend backend : {Backend::cpu, Backend::opencl})
      for (Kernel kernel : {Kernel::tile, Kernel::single, Kernel::measure}) {
        if (backend == Backend::cpu && kernel != Kernel::tile) continue;
        RendererOptions o;
        o.backend = backend;
        o.kernel = kernel;
        Renderer renderer(scene, o);
        for (Fold f : kFolds) {
          const GBuffer g = renderer.render(camera, f);
          // measure: both kernels timed on the first render, the faster kept.
          if (kernel == Kernel::measure)
            EXPECT_TRUE(renderer.kernel() == "tile" || renderer.kernel() == "single") << renderer.kernel();
          EXPECT_EQ(g.fold, f);
          EXPECT_EQ(compare_hits(expected, to_hits(g), 37), "")
              << "view " << view << " backend " << int(backend) << " kernel " << int(kernel) << " fold " << int(f);
        }
      }
  }
}

// The options that arrange the work (braid, merging, culling) and the cost
// model's choice change no bit: every combination against brute force. The
// renderer says what it built and how a render's time went.
TEST(Api, TuningAndTheCostModelsChoiceChangeTheWorkNotTheBits) {
  core::testing::Rng rng(11);
  const core::Scene soup = core::testing::random_scene(rng, 3, 9, 40);
  const Scene scene = to_public(soup);
  const Camera camera = to_camera(core::testing::random_camera(rng, soup.world_bounds()), 41, 27);
  const std::vector<rf_pixel_hit> expected = brute(soup, camera);
  struct Tuning {
    int braid;
    bool merge, cull;
  };
  for (const Tuning t : {Tuning{2, true, true}, Tuning{0, true, true}, Tuning{8, false, true}, Tuning{2, true, false}})
    for (Backend backend : {Backend::cpu, Backend::opencl}) {
      RendererOptions o;
      o.backend = backend;
      o.braid = t.braid;
      o.merge_static = t.merge;
      o.cull = t.cull;
      Renderer renderer(scene, o);
      const AutoChoice choice = renderer.choose_fastest({camera});
      ASSERT_FALSE(choice.predictions.empty());
      EXPECT_EQ(choice.predictions[0].fold, choice.fold);
      EXPECT_EQ(choice.align, 1) << "one view aligns with nothing";
      for (size_t i = 1; i < choice.predictions.size(); ++i)
        EXPECT_LE(choice.predictions[i - 1].total_ms(), choice.predictions[i].total_ms());
      const GBuffer g = renderer.render(camera, choice.fold);
      EXPECT_EQ(compare_hits(expected, to_hits(g), 41), "")
          << "braid " << t.braid << " merge " << t.merge << " cull " << t.cull << " backend " << int(backend);
      EXPECT_EQ(g.stages.trace_ms, g.trace_ms);
      EXPECT_EQ(g.top_level.scene_instances, soup.instances.size());
      EXPECT_EQ(g.kernel, renderer.kernel());
      if (!t.cull) EXPECT_GE(g.top_level.traced_instances, soup.instances.size()) << "culled without culling";
      const BuildStats b = renderer.build_stats();
      EXPECT_GT(b.sah_cost, 0.0);
      EXPECT_GT(b.depth, 0);
      EXPECT_EQ(renderer.device_buffers().empty(), backend == Backend::cpu);
    }
  RendererOptions bad;
  bad.braid = -1;
  EXPECT_THROW(Renderer(scene, bad), InputError);
  bad = {};
  bad.fast_math = true;
  bad.exact_depth = true;
  EXPECT_THROW(Renderer(scene, bad), InputError);
  Renderer cpu(scene, {Backend::cpu});
  EXPECT_THROW(cpu.choose_fastest({}), InputError);
  EXPECT_THROW(cpu.choose_fastest({camera}, {}, {33}), InputError);
}

// A view as a look-at (the file's camera, the chosen one, the CLI's) makes
// the camera look_at makes, and a shifted window the core's shifted camera.
TEST(Api, ViewsMakeTheCamerasTheirLookAtsMake) {
  View v;
  v.eye = {1.0, 2.0, 5.0};
  v.target = {0.0, 0.5, 0.0};
  v.vfov_degrees = 40.0;
  const Camera a = Camera::from_view(v, 40, 30);
  EXPECT_EQ(a.to_bytes(), Camera::look_at(v.eye, v.target, v.up, 40.0, 40, 30).to_bytes());
  core::CameraSpec spec;
  spec.eye = {1.0, 2.0, 5.0};
  spec.look_at = {0.0, 0.5, 0.0};
  spec.vfov_degrees = 40.0;
  const core::Camera shifted = core::make_camera(spec, 40, 30, 0.25, -0.5);
  const Camera b = Camera::from_view(v, 40, 30, 0.25, -0.5);
  EXPECT_EQ(std::memcmp(&b.core().params, &shifted.params, sizeof shifted.params), 0);
  EXPECT_FALSE(b.can_fold_columns() && b.can_fold_rows() && a.to_bytes() == b.to_bytes());
  v.orthographic = true;
  v.half_height = 3.0;
  EXPECT_EQ(Camera::from_view(v, 40, 30).to_bytes(),
            Camera::orthographic(v.eye, v.target, v.up, 3.0, 40, 30).to_bytes());
  EXPECT_THROW(Camera::from_view(v, 40, 30, 101.0, 0.0), InputError);

  core::Scene hall;
  hall.meshes.push_back(core::testing::wound_box(true, glm::vec3(5.0f, 1.0f, 1.0f)));
  hall.instances.push_back(core::Instance{});
  ViewSource source = ViewSource::file_camera;
  const View chosen = to_public(hall).default_view(&source);
  EXPECT_EQ(source, ViewSource::interior);
  EXPECT_EQ(chosen.eye, (Vec3{0.0, 0.0, 0.0}));
}

TEST(Api, MatrixCameraInEitherConventionEqualsTheLookAtCamera) {
  const Scene scene = Scene::load(RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  const Camera a = scene.default_camera(64, 36);
  Renderer renderer(scene);
  const GBuffer ga = renderer.render(a, Fold::xy);
  for (CameraConvention c : {CameraConvention::opengl, CameraConvention::opencv}) {
    const Camera b = Camera::from_matrix(a.camera_to_world(c), a.intrinsics(), 64, 36, c);
    const Intrinsics ka = a.intrinsics(), kb = b.intrinsics();
    EXPECT_EQ(ka.fx, kb.fx);
    EXPECT_EQ(ka.cx, 32.0);
    EXPECT_EQ(ka.cy, 18.0);
    EXPECT_EQ(kb.cx, ka.cx);
    EXPECT_EQ(kb.cy, ka.cy);
    EXPECT_TRUE(b.can_fold_columns() && b.can_fold_rows());
    const GBuffer gb = renderer.render(b, Fold::xy);
    // The matrix went through double unchanged, so the rays are the same floats.
    EXPECT_EQ(compare_hits(to_hits(ga), to_hits(gb), 64), "") << "convention " << int(c);
  }
  // OpenCV's axes are OpenGL's with y and z negated.
  const Matrix4 gl = a.camera_to_world(CameraConvention::opengl), cv = a.camera_to_world(CameraConvention::opencv);
  for (int r = 0; r < 3; ++r) {
    EXPECT_EQ(cv[4 * r], gl[4 * r]);
    EXPECT_EQ(cv[4 * r + 1], -gl[4 * r + 1]);
    EXPECT_EQ(cv[4 * r + 2], -gl[4 * r + 2]);
    EXPECT_EQ(cv[4 * r + 3], gl[4 * r + 3]);
  }
}

TEST(Api, OffGridPrincipalPointIsExactAndFoldsOnlyTheAxisThatAllows) {
  core::testing::Rng rng(11);
  const core::Scene soup = core::testing::random_scene(rng, 2, 5, 60);
  const Scene scene = to_public(soup);
  const core::CameraSpec spec = core::testing::random_camera(rng, soup.world_bounds());
  const Camera look = to_camera(spec, 41, 29);
  // fx != fy, cx off the half-pixel grid, cy on it (one pixel off centre).
  const Intrinsics k{31.7, 29.3, 20.5 + 0.3, 14.5 + 1.0};
  const Camera camera = Camera::from_matrix(look.camera_to_world(), k, 41, 29, CameraConvention::opengl);
  EXPECT_FALSE(camera.can_fold_columns());
  EXPECT_TRUE(camera.can_fold_rows());
  const Intrinsics back = camera.intrinsics();
  EXPECT_NEAR(back.fx, k.fx, 1e-12);
  EXPECT_NEAR(back.fy, k.fy, 1e-12);
  EXPECT_NEAR(back.cx, k.cx, 1e-12);
  EXPECT_NEAR(back.cy, k.cy, 1e-12);
  const std::vector<rf_pixel_hit> expected = brute(soup, camera);
  size_t hits = 0;
  for (const rf_pixel_hit& h : expected) hits += h.instance != RF_INVALID;
  EXPECT_GT(hits, 0u);
  for (Backend backend : {Backend::cpu, Backend::opencl}) {
    RendererOptions o;
    o.backend = backend;
    Renderer renderer(scene, o);
    for (Fold f : kFolds) {
      const GBuffer g = renderer.render(camera, f);
      EXPECT_EQ(g.fold, f == Fold::xy || f == Fold::x ? Fold::x : Fold::none);
      EXPECT_EQ(compare_hits(expected, to_hits(g), 41), "") << "backend " << int(backend) << " fold " << int(f);
    }
  }
  // The ray of pixel (x, y) is the pinhole model's, in world space.
  const Matrix4 m = camera.camera_to_world(CameraConvention::opencv);
  for (int y : {0, 13, 28})
    for (int x : {0, 17, 40}) {
      const double c[3] = {(x + 0.5 - k.cx) / k.fx, (y + 0.5 - k.cy) / k.fy, 1.0};
      double w[3], len = 0.0;
      for (int r = 0; r < 3; ++r) {
        w[r] = m[4 * r] * c[0] + m[4 * r + 1] * c[1] + m[4 * r + 2] * c[2];
        len += w[r] * w[r];
      }
      const Vec3 d = camera.ray_direction(x, y);
      for (int r = 0; r < 3; ++r) EXPECT_NEAR(d[r], w[r] / std::sqrt(len), 1e-12) << x << "," << y;
    }
}

TEST(Api, MovedInstancesEqualASceneBuiltWithThemInPlace) {
  core::testing::Rng rng(5);
  core::Scene soup = core::testing::random_scene(rng, 3, 8, 50);
  Scene moving = to_public(soup);
  const core::CameraSpec spec = core::testing::random_camera(rng, soup.world_bounds());
  const Camera camera = to_camera(spec, 33, 27);
  for (Backend backend : {Backend::cpu, Backend::opencl}) {
    RendererOptions o;
    o.backend = backend;
    Renderer renderer(moving, o);
    for (int frame = 0; frame < 3; ++frame) {
      // Move every other instance: shift it and turn it about its own x.
      for (uint32_t i = frame % 2; i < soup.instances.size(); i += 2) {
        const double a = 0.4 * (frame + 1) + i;
        core::Xform turn(1.0);
        turn[1][1] = std::cos(a);
        turn[1][2] = std::sin(a);
        turn[2][1] = -std::sin(a);
        turn[2][2] = std::cos(a);
        turn[3] = glm::dvec4(0.1 * frame, -0.05 * i, 0.02, 1.0);
        soup.instances[i].world_from_object = turn * soup.instances[i].world_from_object;
        moving.set_transform(i, to_matrix(soup.instances[i].world_from_object));
      }
      const Scene rebuilt = to_public(soup);
      Renderer fresh(rebuilt, o);
      for (Fold f : {Fold::none, Fold::xy})
        EXPECT_EQ(compare_hits(to_hits(fresh.render(camera, f)), to_hits(renderer.render(camera, f)), 33), "")
            << "backend " << int(backend) << " frame " << frame << " fold " << int(f);
    }
  }
}

// Instances that share a transform share one tree (bvh/blas.h); moving one
// builds the trees again with it apart, and every render has the bits of a
// scene built with it in place.
TEST(Api, MovingAMergedInstanceEqualsASceneBuiltWithItInPlace) {
  core::testing::Rng rng(9);
  core::Scene soup = core::testing::random_scene(rng, 3, 6, 50);
  for (size_t i = 1; i < soup.instances.size(); ++i)
    soup.instances[i].world_from_object = soup.instances[0].world_from_object;
  Scene moving = to_public(soup);
  const core::CameraSpec spec = core::testing::random_camera(rng, soup.world_bounds());
  const Camera camera = to_camera(spec, 35, 23);
  for (Backend backend : {Backend::cpu, Backend::opencl}) {
    RendererOptions o;
    o.backend = backend;
    Renderer renderer(moving, o);
    renderer.render(camera);
    EXPECT_TRUE(moving.state()->trees->blas.merged[3]);
    core::Xform shift(1.0);
    shift[3] = glm::dvec4(0.3, -0.2, 0.1, 1.0);
    soup.instances[2].world_from_object = shift * soup.instances[2].world_from_object;
    moving.set_transform(2, to_matrix(soup.instances[2].world_from_object));
    Renderer fresh(to_public(soup), o);
    for (Fold f : {Fold::none, Fold::xy})
      EXPECT_EQ(compare_hits(to_hits(fresh.render(camera, f)), to_hits(renderer.render(camera, f)), 35), "")
          << "backend " << int(backend) << " fold " << int(f);
    EXPECT_FALSE(moving.state()->trees->blas.merged[2]) << "moved, it has a tree of its own";
    EXPECT_TRUE(moving.state()->trees->blas.merged[3]) << "the others still share theirs";
  }
}

TEST(Api, AddingGeometryAfterARenderRebuildsTheTrees) {
  Scene scene;
  const uint32_t tri = scene.add_mesh({-1, -1, 0, 1, -1, 0, 0, 1, 0}, {0, 1, 2}, "triangle");
  const Matrix4 id = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  scene.add_instance(tri, id, "first");
  const Camera camera = Camera::look_at({0, 0, 5}, {0, 0, 0}, {0, 1, 0}, 40.0, 16, 16);
  RendererOptions o;
  o.backend = Backend::cpu;
  Renderer renderer(scene, o);
  const GBuffer one = renderer.render(camera);
  EXPECT_EQ(one.instance_id[8 * 16 + 8], 0u);
  Matrix4 nearer = id;
  nearer[11] = 1.0;  // z + 1: in front of the first
  scene.add_instance(tri, nearer, "second");
  const GBuffer two = renderer.render(camera);
  EXPECT_EQ(two.instance_id[8 * 16 + 8], 1u);
  // Along the same ray, the plane at distance 4 instead of 5 from the eye.
  EXPECT_NEAR(two.depth[8 * 16 + 8], one.depth[8 * 16 + 8] * 0.8f, 1e-5f);
  EXPECT_EQ(scene.instance_names(), (std::vector<std::string>{"first", "second"}));
  EXPECT_EQ(two.instance_id[0], kMiss);
  EXPECT_TRUE(std::isinf(two.depth[0]));
}

template <class E>
std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const E& e) {
    return e.what();
  }
  return "(nothing thrown)";
}

// The streaming form hands over each view once, trace by trace (the 75-degree
// view, alone in its trace, after the six it interrupts), with the bits of
// the list form; an exception from the callback stops it there.
// channels fills only the planes named, with the full render's values.
TEST(Api, ChannelsFillOnlyThePlanesAskedFor) {
  const Scene scene = Scene::load(RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  const Camera cam = scene.default_camera(48, 30);
  Renderer renderer(scene);
  const GBuffer all = renderer.render(cam, Fold::xy);
  const GBuffer some = renderer.render(cam, Fold::xy, kDepth | kInstanceId);
  EXPECT_EQ(some.channels, kDepth | kInstanceId);
  EXPECT_EQ(all.channels, kAllChannels);
  ASSERT_EQ(some.depth.size(), all.depth.size());
  EXPECT_EQ(std::memcmp(some.depth.data(), all.depth.data(), all.depth.size() * sizeof(float)), 0);
  EXPECT_EQ(some.instance_id, all.instance_id);
  EXPECT_TRUE(some.normal.empty() && some.uv.empty() && some.primitive_id.empty());
  EXPECT_EQ(some.hits, all.hits);
  const std::vector<GBuffer> views = renderer.render_views({cam, cam}, Fold::none, 0, kPrimitiveId);
  ASSERT_EQ(views.size(), 2u);
  EXPECT_EQ(views[1].primitive_id, all.primitive_id);
  EXPECT_TRUE(views[1].depth.empty());
  EXPECT_THROW(renderer.render(cam, Fold::none, 0u), InputError);
  EXPECT_THROW(renderer.render(cam, Fold::none, kAnyChannel + 1u), InputError);  // past every channel
  // Without the normal plane the tracers skip the normal: every other plane
  // is still the full render's, on each backend and kernel, in every fold.
  const unsigned no_normal = kAllChannels & ~static_cast<unsigned>(kNormal);
  for (auto [backend, kernel] : {std::pair{Backend::cpu, Kernel::automatic}, std::pair{Backend::opencl, Kernel::tile},
                                 std::pair{Backend::opencl, Kernel::single}}) {
    RendererOptions o;
    o.backend = backend;
    o.kernel = kernel;
    Renderer r(scene, o);
    for (Fold f : {Fold::none, Fold::xy}) {
      const GBuffer g = r.render(cam, f, no_normal);
      const std::string what = "backend " + std::to_string(int(backend)) + " kernel " + std::to_string(int(kernel)) +
                               " fold " + std::to_string(int(f));
      EXPECT_TRUE(g.normal.empty()) << what;
      EXPECT_EQ(std::memcmp(g.depth.data(), all.depth.data(), all.depth.size() * sizeof(float)), 0) << what;
      EXPECT_EQ(std::memcmp(g.uv.data(), all.uv.data(), all.uv.size() * sizeof(float)), 0) << what;
      EXPECT_EQ(g.instance_id, all.instance_id) << what;
      EXPECT_EQ(g.primitive_id, all.primitive_id) << what;
    }
  }
}

TEST(Api, RenderViewsStreamsEachViewOnceTraceByTrace) {
  const Scene scene = Scene::load(RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  const Vec3 eye = scene.default_camera(48, 30).eye();
  std::vector<Camera> views;
  for (int k = 0; k < 7; ++k)
    views.push_back(Camera::look_at({eye[0] + 0.3 * k, eye[1], eye[2] - 0.5 * k}, {0.0, 2.0, 0.0}, {0.0, 1.0, 0.0},
                                    k == 2 ? 75.0 : 50.0, 48, 30));
  Renderer renderer(scene);
  const std::vector<GBuffer> listed = renderer.render_views(views, Fold::xy, 4);
  std::vector<size_t> order;
  renderer.render_views(
      views,
      [&](size_t i, GBuffer&& g) {
        order.push_back(i);
        ASSERT_LT(i, views.size());
        EXPECT_EQ(compare_hits(to_hits(listed[i]), to_hits(g), 48), "") << "view " << i;
        EXPECT_EQ(g.views_in_trace, listed[i].views_in_trace) << "view " << i;
      },
      Fold::xy, 4);
  // Traces of at most 4 (xy holds 8): {0, 1, 3, 4}, {2}, {5, 6}.
  EXPECT_EQ(order, (std::vector<size_t>{0, 1, 3, 4, 2, 5, 6}));
  int calls = 0;
  EXPECT_THROW(renderer.render_views(
                   views,
                   [&](size_t, GBuffer&&) {
                     if (++calls == 2) throw std::runtime_error("stop");
                   },
                   Fold::none, 0),
               std::runtime_error);
  EXPECT_EQ(calls, 2);
}

TEST(Api, RenderViewsEqualsEachViewAloneWhateverTheAlignment) {
  const Scene scene = Scene::load(RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  const Camera base = scene.default_camera(48, 30);
  const Vec3 eye = base.eye();
  std::vector<Camera> views;
  for (int k = 0; k < 5; ++k)  // a dolly, then one view of other intrinsics in the middle
    views.push_back(Camera::look_at({eye[0] + 0.3 * k, eye[1], eye[2] - 0.5 * k}, {0.0, 2.0, 0.0}, {0.0, 1.0, 0.0},
                                    k == 2 ? 75.0 : 50.0, 48, 30));
  const auto pair = Camera::stereo_pair(eye, {0.0, 2.0, 0.0}, {0.0, 1.0, 0.0}, 50.0, 48, 30, 0.2);
  views.push_back(pair[0]);
  views.push_back(pair[1]);
  // The pair is the look-at camera moved baseline / 2 along its right vector.
  const Matrix4 c2w = pair[1].camera_to_world();
  EXPECT_NEAR(pair[1].eye()[0] - pair[0].eye()[0], 0.2 * c2w[0], 1e-12);
  EXPECT_NEAR(pair[1].eye()[2] - pair[0].eye()[2], 0.2 * c2w[8], 1e-12);
  for (Backend backend : {Backend::cpu, Backend::opencl}) {
    RendererOptions o;
    o.backend = backend;
    Renderer renderer(scene, o);
    for (Fold f : {Fold::none, Fold::xy})
      for (int align : {0, 1, 2}) {
        const std::vector<GBuffer> gs = renderer.render_views(views, f, align);
        ASSERT_EQ(gs.size(), views.size());
        for (size_t v = 0; v < views.size(); ++v) {
          const GBuffer alone = renderer.render(views[v], f);
          EXPECT_EQ(compare_hits(to_hits(alone), to_hits(gs[v]), 48), "")
              << "backend " << int(backend) << " fold " << int(f) << " align " << align << " view " << v;
          EXPECT_EQ(gs[v].fold, f);
        }
        // align 0: the six 50-degree views in one trace, the other alone.
        if (align == 0 && f == Fold::none) {
          EXPECT_EQ(gs[0].views_in_trace, 6);
          EXPECT_EQ(gs[2].views_in_trace, 1);
        }
        if (align == 2) {
          EXPECT_EQ(gs[6].views_in_trace, 2);
        }
      }
    EXPECT_THROW(renderer.render_views(views, Fold::none, -1), InputError);
    EXPECT_THROW(renderer.render_views(views, Fold::none, kMaxAlignedViews + 1), InputError);
    EXPECT_TRUE(renderer.render_views({}, Fold::none).empty());
  }
  EXPECT_THROW(Camera::stereo_pair(eye, {0.0, 2.0, 0.0}, {0.0, 1.0, 0.0}, 50.0, 48, 30, 0.0), InputError);
}

TEST(Api, ExactDepthOfViewsTracedTogetherEqualsEachAlone) {
  // A pass of several views reads each view's part of the exact depth's
  // table; its bits are each view's alone, on both backends and folds, and
  // only the depth differs from the float render's.
  const Scene scene = Scene::load(RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  const Camera base = scene.default_camera(48, 30);
  const Vec3 eye = base.eye();
  std::vector<Camera> views;
  for (int k = 0; k < 4; ++k)
    views.push_back(Camera::look_at({eye[0] + 0.4 * k, eye[1] - 0.2 * k, eye[2] - 0.5 * k}, {0.0, 2.0, 0.0},
                                    {0.0, 1.0, 0.0}, 50.0, 48, 30));
  for (Backend backend : {Backend::cpu, Backend::opencl}) {
    RendererOptions o;
    o.backend = backend;
    Renderer plain(scene, o);
    o.exact_depth = true;
    Renderer exact(scene, o);
    for (Fold f : {Fold::none, Fold::xy}) {
      const std::vector<GBuffer> gs = exact.render_views(views, f, 0);
      ASSERT_EQ(gs.size(), views.size());
      EXPECT_EQ(gs[0].views_in_trace, 4);
      size_t changed = 0;
      for (size_t v = 0; v < views.size(); ++v) {
        EXPECT_TRUE(gs[v].exact_depth);
        EXPECT_EQ(compare_hits(to_hits(exact.render(views[v], f)), to_hits(gs[v]), 48), "")
            << "backend " << int(backend) << " fold " << int(f) << " view " << v;
        std::vector<rf_pixel_hit> a = to_hits(plain.render(views[v], f)), b = to_hits(gs[v]);
        for (size_t i = 0; i < a.size(); ++i) {
          changed += a[i].z != b[i].z;
          a[i].z = b[i].z;
        }
        EXPECT_EQ(compare_hits(a, b, 48), "") << "view " << v;
      }
      EXPECT_GT(changed, 0u);
    }
  }
}

TEST(Api, BadInputsThrowWithTheReason) {
  const std::string missing = message_of<InputError>([] { Scene::load("/no/such/file.glb"); });
  EXPECT_NE(missing.find("/no/such/file.glb"), std::string::npos) << missing;
  Scene s;
  EXPECT_NE(message_of<InputError>([&] {
              s.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0}, {0, 1, 3});
            }).find("3 vertices"),
            std::string::npos);
  EXPECT_NE(message_of<InputError>([&] {
              s.add_mesh({0, 0, 0}, {0, 0});
            }).find("whole number of triangles"),
            std::string::npos);
  EXPECT_NE(message_of<InputError>([&] { s.add_mesh({0, 0, NAN}, {}); }).find("not finite"), std::string::npos);
  const Matrix4 id = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  EXPECT_NE(message_of<InputError>([&] { s.add_instance(3, id); }).find("mesh 3 does not exist"), std::string::npos);
  const uint32_t m = s.add_mesh({0, 0, 0, 1, 0, 0, 0, 1, 0}, {0, 1, 2});
  Matrix4 projective = id;
  projective[14] = 1.0;
  EXPECT_NE(message_of<InputError>([&] { s.add_instance(m, projective); }).find("not affine"), std::string::npos);
  const uint32_t i = s.add_instance(m, id);
  Matrix4 far = id;
  far[3] = 1e38;
  EXPECT_NE(message_of<InputError>([&] { s.set_transform(i, far); }).find("2^126"), std::string::npos);
  EXPECT_NE(message_of<InputError>([&] { s.set_transform(i + 1, id); }).find("does not exist"), std::string::npos);

  const Intrinsics k{50, 50, 16, 16};
  Matrix4 scaled = id;
  scaled[0] = 2.0;
  EXPECT_NE(message_of<InputError>([&] {
              Camera::from_matrix(scaled, k, 32, 32, CameraConvention::opencv);
            }).find("not orthonormal"),
            std::string::npos);
  Matrix4 mirrored = id;
  mirrored[0] = -1.0;
  EXPECT_NE(message_of<InputError>([&] {
              Camera::from_matrix(mirrored, k, 32, 32, CameraConvention::opencv);
            }).find("mirror"),
            std::string::npos);
  EXPECT_NE(message_of<InputError>([&] {
              Camera::from_matrix(id, {0, 50, 16, 16}, 32, 32, CameraConvention::opencv);
            }).find("focal lengths"),
            std::string::npos);
  EXPECT_NE(message_of<InputError>([] {
              Camera::look_at({0, 0, 0}, {0, 0, 0}, {0, 1, 0}, 60, 8, 8);
            }).find("distinct"),
            std::string::npos);
  RendererOptions o;
  o.device = "no device is called this";
  EXPECT_NE(message_of<RuntimeFailure>([&] { Renderer r(s, o); }).find("no device is called this"), std::string::npos);
}

std::filesystem::path work_dir(const std::string& name) {
  const std::filesystem::path d = core::testing::scratch_dir("rayfold_api") / name;
  std::filesystem::create_directories(d);
  return d;
}

bool same_bits(const std::vector<float>& a, const std::vector<float>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
}

// A camera sent as bytes (Python's pickle, rayfold.batch) is the same
// camera: the same bytes again and the same render, for a look-at, an
// off-grid matrix and an orthographic camera; other bytes are refused.
TEST(Api, CameraBytesKeepEveryValueAndRefuseOthers) {
  const Scene scene = Scene::load(RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  const Matrix4 pose = {0.6, 0, 0.8, 1.5, 0, 1, 0, 1.2, -0.8, 0, 0.6, 4.0, 0, 0, 0, 1};
  const Camera cameras[] = {
      Camera::look_at({0.3, 1.1, 4.7}, {0, 1, 0}, {0, 1, 0}, 55, 40, 30),
      Camera::from_matrix(pose, {31.3, 29.9, 20.17, 14.9}, 40, 30, CameraConvention::opengl),
      Camera::orthographic({0, 1, 6}, {0, 1, 0}, {0, 1, 0}, 2.5, 40, 30)};
  Renderer renderer(scene);
  for (const Camera& c : cameras) {
    const std::string bytes = c.to_bytes();
    const Camera back = Camera::from_bytes(bytes);
    EXPECT_EQ(back.to_bytes(), bytes);
    const GBuffer a = renderer.render(c, Fold::xy), b = renderer.render(back, Fold::xy);
    EXPECT_TRUE(same_bits(a.depth, b.depth) && a.instance_id == b.instance_id && same_bits(a.normal, b.normal));
    EXPECT_EQ(a.fold, b.fold);
  }
  const std::string bytes = cameras[0].to_bytes();
  EXPECT_NE(message_of<InputError>([&] { Camera::from_bytes(bytes.substr(1)); }).find("not a camera"),
            std::string::npos);
  std::string other = bytes;
  other[5] = 2;  // another format version
  EXPECT_NE(message_of<InputError>([&] { Camera::from_bytes(other); }).find("format 1"), std::string::npos);
}

// write_exr then read_exr gives back every plane the G-buffer has, bit for
// bit, and only those; a G-buffer whose planes do not fit its size is refused.
TEST(Api, ExrFilesReadBackBitForBitWithThePlanesWritten) {
  const std::filesystem::path d = work_dir("exr");
  const Scene scene = Scene::load(RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  const Camera cam = scene.default_camera(48, 30);
  Renderer renderer(scene);
  const GBuffer all = renderer.render(cam, Fold::xy);
  write_exr((d / "all.exr").string(), all, cam, scene);
  const GBuffer back = read_exr((d / "all.exr").string());
  EXPECT_EQ(back.channels, kAllChannels);
  EXPECT_EQ(back.width, 48);
  EXPECT_EQ(back.height, 30);
  EXPECT_TRUE(same_bits(back.depth, all.depth) && same_bits(back.normal, all.normal) && same_bits(back.uv, all.uv));
  EXPECT_EQ(back.instance_id, all.instance_id);
  EXPECT_EQ(back.primitive_id, all.primitive_id);
  EXPECT_EQ(back.hits, all.hits);
  const GBuffer some = renderer.render(cam, Fold::none, kDepth | kPrimitiveId);
  write_exr((d / "some.exr").string(), some, cam, scene);
  const GBuffer some_back = read_exr((d / "some.exr").string());
  EXPECT_EQ(some_back.channels, kDepth | kPrimitiveId);
  EXPECT_TRUE(same_bits(some_back.depth, all.depth));
  EXPECT_EQ(some_back.primitive_id, all.primitive_id);
  EXPECT_TRUE(some_back.normal.empty() && some_back.instance_id.empty());
  GBuffer cut = all;
  cut.uv.pop_back();
  EXPECT_NE(message_of<InputError>([&] {
              write_exr((d / "cut.exr").string(), cut, cam, scene);
            }).find("barycentrics (uv) plane holds 2879 values, not the 2880"),
            std::string::npos);
  EXPECT_NE(message_of<InputError>([&] {
              write_exr((d / "small.exr").string(), all, scene.default_camera(24, 30), scene);
            }).find("48x30, its camera 24x30"),
            std::string::npos);
  // Another scene's names in the header: a slip in a loop over scenes.
  Scene one;
  one.add_instance(one.add_mesh(std::vector<float>{-1, -1, -4, 1, -1, -4, 0, 1, -4}, {0, 1, 2}), kIdentity);
  uint32_t largest = 0;
  for (uint32_t id : all.instance_id)
    if (id != kMiss) largest = std::max(largest, id);
  ASSERT_GT(largest, 0u);
  EXPECT_NE(message_of<InputError>([&] {
              write_exr((d / "other.exr").string(), all, cam, one);
            }).find("instance_id holds " + std::to_string(largest) + ", but the scene has 1 instance:"),
            std::string::npos);
  GBuffer labelled = all;  // a label past the scene's table (it has none: only 0)
  labelled.label.assign(all.instance_id.size(), 0u);
  labelled.label[7] = 3;
  labelled.channels |= kLabel;
  EXPECT_NE(message_of<InputError>([&] {
              write_exr((d / "other.exr").string(), labelled, cam, scene);
            }).find("label holds 3, but the scene has 1 label:"),
            std::string::npos);
  // A folder that is not there is the caller's slip, not the machine's failure.
  EXPECT_NE(message_of<InputError>([&] {
              write_exr((d / "nowhere" / "x.exr").string(), all, cam, scene);
            }).find("write_exr: its folder " + (d / "nowhere").string() + " does not exist"),
            std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(d / "nowhere"));
  // A view that hits nothing has no id to check.
  GBuffer empty = all;
  std::fill(empty.instance_id.begin(), empty.instance_id.end(), kMiss);
  write_exr((d / "empty.exr").string(), empty, cam, one);
  EXPECT_TRUE(std::filesystem::exists(d / "empty.exr"));
  EXPECT_FALSE(std::filesystem::exists(d / "cut.exr") || std::filesystem::exists(d / "small.exr") ||
               std::filesystem::exists(d / "other.exr"));
  EXPECT_NE(message_of<InputError>([&] { read_exr((d / "none.exr").string()); }).find("none.exr"),
            std::string::npos);
  // Every lossless compression reads back the same bits; none is the
  // largest, zip smaller; lossy ones are refused by name.
  std::vector<uintmax_t> sizes;
  for (const char* name : {"none", "rle", "zips", "zip", "piz"}) {
    const std::string path = (d / (std::string("c_") + name + ".exr")).string();
    write_exr(path, all, cam, scene, exr_compression(name));
    const GBuffer c = read_exr(path);
    EXPECT_TRUE(same_bits(c.depth, all.depth) && same_bits(c.normal, all.normal) && same_bits(c.uv, all.uv)) << name;
    EXPECT_EQ(c.instance_id, all.instance_id) << name;
    EXPECT_EQ(c.primitive_id, all.primitive_id) << name;
    sizes.push_back(std::filesystem::file_size(path));
  }
  EXPECT_GT(sizes[0], 48u * 30u * 32u) << "none holds every byte";
  EXPECT_LT(sizes[3], sizes[0]) << "zip compresses";
  EXPECT_NE(message_of<InputError>([] { exr_compression("dwaa"); }).find("lossy"), std::string::npos);
  EXPECT_NE(message_of<InputError>([] { exr_compression("gzip"); }).find("none, rle, zips, zip, piz"),
            std::string::npos);
}

// Camera::from_file tells a camera list from a transforms.json by content.
TEST(Api, CameraFilesAreReadByWhatTheyHold) {
  const std::filesystem::path d = work_dir("camera_files");
  std::ofstream(d / "list.json") << R"({"width": 40, "height": 30, "cameras": [
      {"eye": [0, 1, 5], "look_at": [0, 1, 0]}, {"eye": [1, 1, 5], "look_at": [0, 1, 0], "fx": 30, "fy": 30,
      "cx": 20, "cy": 15}]})";
  const auto list = Camera::from_file((d / "list.json").string());
  ASSERT_EQ(list.size(), 2u);
  EXPECT_EQ(list[0].first, "0");
  EXPECT_EQ(list[1].first, "1");
  EXPECT_EQ(list[1].second.intrinsics().fx, 30.0);
  EXPECT_EQ(list[0].second.to_bytes(),
            Camera::look_at({0, 1, 5}, {0, 1, 0}, {0, 1, 0}, 60, 40, 30).to_bytes());
  std::ofstream(d / "transforms.json") << R"({"camera_angle_x": 0.9, "frames": [{"file_path": "a.png",
      "transform_matrix": [[1, 0, 0, 0], [0, 1, 0, 1], [0, 0, 1, 5], [0, 0, 0, 1]]}]})";
  const auto nerf = Camera::from_file((d / "transforms.json").string(), 40, 30);
  ASSERT_EQ(nerf.size(), 1u);
  EXPECT_EQ(nerf[0].first, "a.png");
  EXPECT_EQ(nerf[0].second.width(), 40);
  EXPECT_NE(message_of<InputError>([&] {
              Camera::from_file((d / "list.json").string(), 40, 30);
            }).find("width and height does not combine"),
            std::string::npos);
}

// --device cpu and gpu name a type: a cluster's CPU workers take the CPU
// device even where a GPU would be the default.
TEST(Api, DeviceTypesPickTheFirstDeviceOfThatType) {
  const Scene scene = Scene::load(RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  const std::vector<core::DeviceInfo> devices = core::list_devices();
  RendererOptions o;
  o.device = "cpu";
  bool any_cpu = false, only_cpus = true;
  for (const core::DeviceInfo& d : devices) {
    any_cpu |= d.is_cpu;
    only_cpus &= d.is_cpu;
  }
  if (any_cpu) {
    std::string first_cpu;
    for (const core::DeviceInfo& d : devices)
      if (d.is_cpu && first_cpu.empty()) first_cpu = d.name;
    EXPECT_NE(Renderer(scene, o).device_name().find(first_cpu), std::string::npos);
  }
  o.device = "gpu";
  if (only_cpus) {
    EXPECT_NE(message_of<RuntimeFailure>([&] { Renderer r(scene, o); }).find("no OpenCL device is a gpu; the devices"),
              std::string::npos);
  }
}

// The command line loads the OpenCL drivers while it reads the scene
// (core::OpenClPreload). What is found after that load is what a process
// that did not load ahead finds. The load counts as the process's first use
// of OpenCL: a child forked after it started is refused OpenCL, as after any
// other first use (check_not_forked). Needs a process that has not used
// OpenCL before (ctest runs each test in its own).
TEST(Api, LoadingOpenClAheadFindsTheSameDevicesAndCountsAsAFirstUse) {
  int fds[2];
  ASSERT_EQ(::pipe(fds), 0);
  const pid_t lister = ::fork();  // before this process uses OpenCL
  ASSERT_GE(lister, 0);
  if (lister == 0) {
    try {
      const std::string found = core::describe_devices(core::list_devices());
      const bool whole = ::write(fds[1], found.data(), found.size()) == static_cast<ssize_t>(found.size());
      ::_exit(whole ? 0 : 1);
    } catch (...) {
      ::_exit(2);
    }
  }
  ::close(fds[1]);
  std::string without;
  char buf[256];
  for (ssize_t n; (n = ::read(fds[0], buf, sizeof buf)) > 0;) without.append(buf, static_cast<size_t>(n));
  ::close(fds[0]);
  int status = 0;
  ASSERT_EQ(::waitpid(lister, &status, 0), lister);
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0)
      << "the lister child failed (exit " << WEXITSTATUS(status) << "): run this test in a process of its own";
  std::string with;
  {
    const core::OpenClPreload preload;
    const pid_t child = ::fork();  // the load started, perhaps not finished: the child must not exit normally
    ASSERT_GE(child, 0);
    if (child == 0) {
      try {
        core::check_not_forked();
      } catch (const RuntimeFailure&) {
        ::_exit(0);
      }
      ::_exit(1);
    }
    ASSERT_EQ(::waitpid(child, &status, 0), child);
    EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << "the child was not refused OpenCL";
    const core::OpenClPreload again;  // a second one only waits
    with = core::describe_devices(core::list_devices());
  }
  EXPECT_EQ(with, without);
  EXPECT_FALSE(without.empty());
}

// A scene saved with its trees and loaded back renders the original's bits
// in every backend, kernel and fold, also with an instance moved before the
// save and another after the load; the loaded renderer takes the saved
// trees (the very arrays, not a rebuild).
TEST(Api, SavedScenesRenderTheOriginalsBitsWithTheirTrees) {
  core::testing::Rng rng(23);
  const core::Scene soup = core::testing::random_scene(rng, 3, 8, 60);
  Scene scene = to_public(soup);
  const Matrix4 moved = {0, -1, 0, 0.5, 1, 0, 0, 0.25, 0, 0, 1, -0.5, 0, 0, 0, 1};
  scene.set_transform(3, moved);
  const std::filesystem::path d = work_dir("saved");
  scene.save((d / "s.rfscene").string());
  const Scene loaded = Scene::load((d / "s.rfscene").string());
  EXPECT_EQ(loaded.instance_names(), scene.instance_names());
  EXPECT_EQ(Scene::from_bytes(loaded.to_bytes()).to_bytes(), loaded.to_bytes());
  EXPECT_EQ(loaded.state()->trees->blas.nodes.size(), scene.state()->trees->blas.nodes.size());
  for (int view = 0; view < 2; ++view) {
    const core::CameraSpec spec = core::testing::random_camera(rng, soup.world_bounds());
    const Camera camera = to_camera(spec, 33, 21);
    for (auto [backend, kernel] : {std::pair{Backend::cpu, Kernel::automatic}, std::pair{Backend::opencl, Kernel::tile},
                                   std::pair{Backend::opencl, Kernel::single}}) {
      RendererOptions o;
      o.backend = backend;
      o.kernel = kernel;
      Renderer original(scene, o), from_file(loaded, o);
      for (Fold f : kFolds)
        EXPECT_EQ(compare_hits(to_hits(original.render(camera, f)), to_hits(from_file.render(camera, f)), 33), "")
            << "view " << view << " backend " << int(backend) << " kernel " << int(kernel) << " fold " << int(f);
    }
  }
  // Moved after the load: as the original moved the same way.
  Scene copy = Scene::from_bytes(scene.to_bytes());
  const Matrix4 again = {1, 0, 0, -0.75, 0, 1, 0, 0.5, 0, 0, 1, 0, 0, 0, 0, 1};
  scene.set_transform(5, again);
  copy.set_transform(5, again);
  const Camera camera = Camera::look_at({0.5, 0.7, 9}, {0, 0, 0}, {0, 1, 0}, 70, 33, 21);
  Renderer a(scene), b(copy);
  EXPECT_EQ(compare_hits(to_hits(a.render(camera, Fold::xy)), to_hits(b.render(camera, Fold::xy)), 33), "");
  EXPECT_NE(message_of<InputError>([&] {
              LoadOptions o;
              o.camera = 0;
              Scene::load((d / "s.rfscene").string(), o);
            }).find("options do not apply"),
            std::string::npos);
}

// Damaged, cut or foreign bytes are refused, saying which; so are bytes
// whose checksum holds but whose trees point outside their arrays or round
// a cycle (a writer's bug, or a crafted file), which a kernel would follow.
TEST(Api, SceneBytesThatAreNotWholeAreRefusedSayingWhy) {
  const Scene scene = Scene::load(RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  const std::string bytes = scene.to_bytes();
  auto why = [](const std::string& b) { return message_of<InputError>([&] { Scene::from_bytes(b, "x.rfscene"); }); };
  for (size_t at : {size_t{0}, size_t{16}, size_t{20}, size_t{24}, size_t{40}, bytes.size() / 2, bytes.size() - 1}) {
    std::string flipped = bytes;
    flipped[at] ^= 0x10;
    EXPECT_NE(why(flipped).find("x.rfscene"), std::string::npos) << "byte " << at;
  }
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 1;
  EXPECT_NE(why(flipped).find("checksum does not match"), std::string::npos);
  for (size_t n : {size_t{0}, size_t{10}, size_t{40}, bytes.size() - 9, bytes.size() - 1})
    EXPECT_NE(why(bytes.substr(0, n)).find("x.rfscene"), std::string::npos) << n << " bytes";
  EXPECT_NE(why(bytes + "x").find("payload bytes"), std::string::npos);
  std::string format = bytes;
  format[16] = 9;
  EXPECT_NE(why(format).find("format 9"), std::string::npos);

  core::SceneFile file{scene.state()->scene, *scene.state()->trees, "", {}};
  EXPECT_NE(why(core::scene_file_bytes(file, "0.0.1")).find("written by rayfold 0.0.1"), std::string::npos);
  core::SceneFile bad = file;
  const uint32_t root = bad.data.blas.roots[0];
  bad.data.blas.nodes[root].first = static_cast<uint32_t>(bad.data.blas.nodes.size());
  EXPECT_NE(why(core::scene_file_bytes(bad, RAYFOLD_VERSION_STRING)).find("points outside"), std::string::npos);
  bad = file;
  for (rf_wide_node& w : bad.data.wide_nodes)
    for (int k = 0; k < 4; ++k)
      if (w.count[k] == 0) w.child[k] = static_cast<uint32_t>(&w - bad.data.wide_nodes.data());  // itself
  EXPECT_NE(why(core::scene_file_bytes(bad, RAYFOLD_VERSION_STRING)).find("cycle"), std::string::npos);
  bad = file;
  bad.data.blas.tris[0].inst = static_cast<uint32_t>(bad.scene.instances.size());  // a hit would name no instance
  EXPECT_NE(why(core::scene_file_bytes(bad, RAYFOLD_VERSION_STRING)).find("past the last"), std::string::npos);
  bad = file;
  bad.data.blas.traced_by[0] = static_cast<uint32_t>(bad.scene.instances.size());
  EXPECT_NE(why(core::scene_file_bytes(bad, RAYFOLD_VERSION_STRING)).find("traced by"), std::string::npos);
  bad = file;
  bad.data.braid_offsets.pop_back();
  EXPECT_NE(why(core::scene_file_bytes(bad, RAYFOLD_VERSION_STRING)).find("do not match"), std::string::npos);
  {
    // Cuts that leave part of the last instance's tree out, where a
    // triangle names an instance past the last: ray queries trace whole
    // trees, so the tree itself is checked.
    bad = file;
    const uint32_t last = static_cast<uint32_t>(bad.scene.instances.size() - 1);
    const uint32_t root = bad.data.blas.instance_roots.at(last);
    ASSERT_NE(root, RF_INVALID);
    ASSERT_EQ(bad.data.blas.nodes[root].meta, 0u) << "the last instance's tree is a leaf";
    for (uint32_t c = bad.data.braid_offsets[last]; c < bad.data.braid_offsets[last + 1]; ++c) {
      bad.data.braid_nodes[c] = bad.data.blas.nodes[root].first;
      bad.data.braid_wide[c] = RF_INVALID;
    }
    uint32_t x = bad.data.blas.nodes[root].first + 1;
    while (bad.data.blas.nodes[x].meta == 0) x = bad.data.blas.nodes[x].first;
    bad.data.blas.tris[bad.data.blas.nodes[x].first].inst = 1;
    EXPECT_NE(why(core::scene_file_bytes(bad, RAYFOLD_VERSION_STRING)).find("instance's tree has triangles naming"),
              std::string::npos);
  }
  EXPECT_NO_THROW(Scene::from_bytes(core::scene_file_bytes(file, RAYFOLD_VERSION_STRING)));
}

// One renderer keeps a ray list while the image size and principal point
// stay (renders of other fields of view reuse it): each view still has the
// bits a fresh renderer gives it, folded too, and after another size.
TEST(Api, ViewsOfAnotherFieldOfViewKeepTheirBitsWithTheKeptRayList) {
  const Scene scene = Scene::load(RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  const Vec3 eye = scene.default_camera(48, 30).eye();
  std::vector<Camera> views;
  for (double fov : {40.0, 75.0, 52.5})
    views.push_back(Camera::look_at(eye, {0.0, 2.0, 0.0}, {0.0, 1.0, 0.0}, fov, 41, 27));
  views.push_back(Camera::look_at(eye, {0.0, 2.0, 0.0}, {0.0, 1.0, 0.0}, 60.0, 40, 28));
  views.push_back(views[1]);
  for (Backend backend : {Backend::cpu, Backend::opencl}) {
    RendererOptions o;
    o.backend = backend;
    Renderer kept(scene, o);
    for (Fold f : kFolds)
      for (size_t v = 0; v < views.size(); ++v) {
        Renderer fresh(scene, o);
        EXPECT_EQ(compare_hits(to_hits(fresh.render(views[v], f)), to_hits(kept.render(views[v], f)),
                               views[v].width()),
                  "")
            << "backend " << int(backend) << " fold " << int(f) << " view " << v;
      }
  }
}

// RAYFOLD_READBACK for one scope (the renderers made inside read it).
class ReadbackEnv {
 public:
  explicit ReadbackEnv(const char* value) { setenv("RAYFOLD_READBACK", value, 1); }
  ~ReadbackEnv() { unsetenv("RAYFOLD_READBACK"); }
};

std::string plane_difference(const GBuffer& want, const GBuffer& got) {
  auto differs = [](const auto& a, const auto& b) {
    return a.size() != b.size() || (!a.empty() && std::memcmp(a.data(), b.data(), a.size() * sizeof(a[0])) != 0);
  };
  std::string d;
  if (differs(want.depth, got.depth)) d += " depth";
  if (differs(want.normal, got.normal)) d += " normal";
  if (differs(want.uv, got.uv)) d += " uv";
  if (differs(want.instance_id, got.instance_id)) d += " instance_id";
  if (differs(want.primitive_id, got.primitive_id)) d += " primitive_id";
  if (want.hits != got.hits) d += " hits " + std::to_string(want.hits) + " vs " + std::to_string(got.hits);
  if (want.channels != got.channels) d += " channels";
  if (want.views_in_trace != got.views_in_trace) d += " views_in_trace";
  return d;
}

// The packed readback (what a GPU reads back: only the planes asked for,
// packed on the device, passes pipelined) gives the bits of the host
// layout's, plane for plane, in every channel set, fold, alignment and
// kernel; PoCL is made to take it through RAYFOLD_READBACK.
TEST(Api, PackedReadbackGivesTheHostLayoutsBitsInEveryChannelSet) {
  const Scene scene = Scene::load(RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  const Vec3 eye = scene.default_camera(48, 30).eye();
  std::vector<Camera> views;
  // 37x23 is no multiple of the pack kernel's 256-pixel work-groups; the
  // 75-degree view and the other size make passes of their own.
  for (int k = 0; k < 9; ++k)
    views.push_back(Camera::look_at({eye[0] + 0.3 * k, eye[1], eye[2] - 0.5 * k}, {0.0, 2.0, 0.0}, {0.0, 1.0, 0.0},
                                    k == 2 ? 75.0 : 50.0, k == 7 ? 20 : 37, k == 7 ? 16 : 23));
  for (Kernel kernel : {Kernel::tile, Kernel::single}) {
    RendererOptions o;
    o.kernel = kernel;
    std::unique_ptr<Renderer> packed, hits;
    {
      ReadbackEnv env("packed");
      packed = std::make_unique<Renderer>(scene, o);
      core::PipelineOptions co;
      co.kernel = kernel;
      core::Pipeline probe(scene.state()->scene, co, scene.state()->trees);
      ASSERT_TRUE(probe.packs_planes());
      core::FrameOptions fo;
      fo.planes = true;
      fo.channels = kDepth | kInstanceId;
      core::RenderResult r;
      probe.render_views_into(r, {views[0].core()}, 1, fo);
      EXPECT_TRUE(r.hits.empty());
      ASSERT_NE(r.readback.words, nullptr);
      EXPECT_EQ(r.readback.words_per_view, 2u * 37 * 23);
    }
    {
      ReadbackEnv env("hits");
      hits = std::make_unique<Renderer>(scene, o);
    }
    for (unsigned channels : {unsigned{kAllChannels}, kDepth | kInstanceId, unsigned{kNormal}, kUv | kPrimitiveId})
      for (Fold f : {Fold::none, Fold::xy})
        for (int align : {0, 1}) {
          const std::vector<GBuffer> want = hits->render_views(views, f, align, channels);
          const std::vector<GBuffer> got = packed->render_views(views, f, align, channels);
          ASSERT_EQ(got.size(), views.size());
          for (size_t v = 0; v < views.size(); ++v)
            EXPECT_EQ(plane_difference(want[v], got[v]), "") << "kernel " << int(kernel) << " channels " << channels
                                                             << " fold " << int(f) << " align " << align << " view " << v;
          EXPECT_GT(want[0].hits, 0u);
          EXPECT_EQ(plane_difference(hits->render(views[7], f, channels), packed->render(views[7], f, channels)), "");
        }
    // A consumer that throws mid-stream leaves a pass in flight; the next
    // render waits for it and is whole.
    int calls = 0;
    EXPECT_THROW(packed->render_views(
                     views, [&](size_t, GBuffer&&) { if (++calls == 1) throw std::runtime_error("stop"); }, Fold::none, 1),
                 std::runtime_error);
    const std::vector<GBuffer> again = packed->render_views(views, Fold::none, 1);
    for (size_t v = 0; v < views.size(); ++v)
      EXPECT_EQ(plane_difference(hits->render(views[v]), again[v]), "") << "view " << v << " after the throw";
  }
  ReadbackEnv env("sideways");
  EXPECT_NE(message_of<InputError>([&] { Renderer r(scene); }).find("RAYFOLD_READBACK is 'sideways'"),
            std::string::npos);
}

// On a CPU device a render of one view has the kernel write the G-buffer's
// planes in place (FrameOptions::planes_in_place) instead of 32-byte hits
// the host turns into planes. Its planes and hit count are the bits of the
// hits path (render_views, which takes it) and of the CPU reference, for
// each kernel, fold, depth kind and channel set, on a size that is no
// multiple of a tile, rendered into a G-buffer of another size before; and
// the core takes that path for such a render. The public render_into takes
// it under RAYFOLD_PLANES_IN_PLACE=1 (by default records and a host copy,
// measured faster), set here for the renderers made below.
TEST(Api, PlanesWrittenInPlaceHaveTheHitPathsBits) {
  const Scene scene = Scene::load(RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  const Camera persp = scene.default_camera(37, 23);
  const Camera ortho = Camera::orthographic(persp.eye(), {0.0, 2.0, 0.0}, {0.0, 1.0, 0.0}, 6.0, 29, 19);
  {
    const Renderer builds_the_trees(scene);
    core::PipelineOptions co;
    co.device_hint = "cpu";  // the path is a CPU device's; a GPU, found first by default, packs its planes
    core::Pipeline probe(scene.state()->scene, co, scene.state()->trees);
    ASSERT_FALSE(probe.packs_planes()) << "not a CPU device: the in-place path is not what this test checks";
    std::vector<float> z(37 * 23, NAN);
    std::vector<uint32_t> inst(37 * 23, 7u);
    core::AnswerPlanes targets;
    targets.z = z.data();
    targets.instance = inst.data();
    core::FrameOptions fo;
    fo.planes = true;
    fo.channels = kDepth | kInstanceId;
    fo.planes_in_place = &targets;
    core::RenderResult r;
    probe.render_into(r, persp.core(), 1, fo);
    EXPECT_TRUE(r.readback.in_place);
    EXPECT_TRUE(r.hits.empty());
    size_t hits = 0;
    for (size_t i = 0; i < z.size(); ++i) {
      hits += inst[i] != RF_INVALID;
      EXPECT_EQ(inst[i] != RF_INVALID, std::isfinite(z[i])) << "pixel " << i << ": " << z[i] << ", " << inst[i];
    }
    EXPECT_GT(hits, z.size() / 4);
  }
  const unsigned channel_sets[] = {kAllChannels, kDepth, kInstanceId, kDepth | kUv | kPrimitiveId,
                                   kNormal | kUv};  // the last counts hits through the hits path
  RendererOptions ref_options;
  ref_options.backend = Backend::cpu;
  setenv("RAYFOLD_PLANES_IN_PLACE", "1", 1);
  struct Unset {
    ~Unset() { unsetenv("RAYFOLD_PLANES_IN_PLACE"); }
  } unset;
  for (Kernel kernel : {Kernel::tile, Kernel::single})
    for (Depth depth : {Depth::distance, Depth::planar})
      for (bool exact : {false, true}) {
        RendererOptions o;
        o.device = "cpu";
        o.kernel = kernel;
        o.depth = depth;
        o.exact_depth = exact;
        ref_options.depth = depth;
        ref_options.exact_depth = exact;
        Renderer cl(scene, o), cpu(scene, ref_options);
        GBuffer g = cl.render(scene.default_camera(20, 16), Fold::none);  // planes of another size to write over
        for (const Camera* cam : {&persp, &ortho})
          for (Fold f : kFolds)
            for (unsigned channels : channel_sets) {
              const std::string what = "kernel " + std::to_string(int(kernel)) + " depth " +
                                       std::to_string(int(depth)) + " exact " + std::to_string(exact) +
                                       (cam == &ortho ? " ortho" : " perspective") + " fold " + std::to_string(int(f)) +
                                       " channels " + std::to_string(channels);
              cl.render_into(g, *cam, f, channels);
              const GBuffer hits_path = cl.render_views({*cam}, f, 0, channels).at(0);
              EXPECT_EQ(plane_difference(hits_path, g), "") << what;
              EXPECT_EQ(plane_difference(cpu.render(*cam, f, channels), g), "") << what;
              EXPECT_GT(g.hits, 0u) << what;
            }
      }
}

// render_views' prepare hands each view its planes: sized ones full of NaN
// are written over whole (the bits of render(view)), the wrong size is
// resized, and prepare sees every view once with its index.
TEST(Api, RenderViewsWritesOverThePlanesPrepareGives) {
  const Scene scene = Scene::load(RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  Renderer renderer(scene);
  std::vector<Camera> views;
  for (int k = 0; k < 3; ++k)
    views.push_back(Camera::look_at({0.3 * k, 2.0, 6.0 - k}, {0.0, 2.0, 0.0}, {0.0, 1.0, 0.0}, 50.0, 40 + 8 * k, 24));
  std::vector<int> prepared(views.size(), 0);
  std::vector<GBuffer> got(views.size());
  std::vector<const void*> normal_memory(views.size());
  renderer.render_views(
      views, [&](size_t i, GBuffer&& g) { got[i] = std::move(g); }, Fold::xy, 0, kAllChannels,
      [&](size_t i, GBuffer& g) {
        prepared[i]++;
        const size_t n = static_cast<size_t>(views[i].width()) * views[i].height();
        g.depth.assign(i == 1 ? n + 5 : n, NAN);  // view 1's is the wrong size
        g.normal.assign(3 * n, NAN);
        g.uv.assign(2 * n, NAN);
        g.instance_id.assign(n, 7u);
        g.primitive_id.assign(n, 7u);
        normal_memory[i] = g.normal.data();
      });
  for (size_t i = 0; i < views.size(); ++i) {
    EXPECT_EQ(prepared[i], 1) << "view " << i;
    EXPECT_EQ(static_cast<const void*>(got[i].normal.data()), normal_memory[i]) << "view " << i << ": not written in place";
    const GBuffer want = renderer.render(views[i], Fold::xy);
    auto same_bits = [](const std::vector<float>& a, const std::vector<float>& b) {
      return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(float)) == 0;
    };
    EXPECT_TRUE(same_bits(got[i].depth, want.depth)) << "view " << i;
    EXPECT_TRUE(same_bits(got[i].normal, want.normal)) << "view " << i;
    EXPECT_TRUE(same_bits(got[i].uv, want.uv)) << "view " << i;
    EXPECT_EQ(got[i].instance_id, want.instance_id) << "view " << i;
    EXPECT_EQ(got[i].primitive_id, want.primitive_id) << "view " << i;
  }
}

// The double reference against hand-computed distances: a square at z = 0
// seen from z = 5 lies 5 / -d.z along each pixel's unit ray, to double
// rounding (a float render is only within float rounding); moving the square
// moves the reference (its trees follow set_transform); outside it, misses.
TEST(Api, ReferenceDepthIsTheHandComputedDistanceInDouble) {
  Scene scene;
  const uint32_t square = scene.add_mesh({-1, -1, 0, 1, -1, 0, 1, 1, 0, -1, 1, 0}, {0, 1, 2, 0, 2, 3}, "square");
  Matrix4 m = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  scene.add_instance(square, m, "square");
  const Camera camera = Camera::look_at({0, 0, 5}, {0, 0, 0}, {0, 1, 0}, 60.0, 24, 16);
  for (double z : {0.0, -1.0}) {
    m[11] = z;
    scene.set_transform(0, m);
    const ReferenceImage ref = render_reference(scene, camera, 2);
    ASSERT_EQ(ref.depth.size(), 24u * 16u);
    EXPECT_EQ(ref.width, 24);
    EXPECT_EQ(ref.height, 16);
    int hits = 0, misses = 0;
    for (int y = 0; y < 16; ++y)
      for (int x = 0; x < 24; ++x) {
        const size_t i = static_cast<size_t>(y) * 24 + x;
        const Vec3 d = camera.ray_direction(x, y);
        const double want = (5.0 - z) / -d[2];
        const Vec3 at = {want * d[0], want * d[1], 5.0 + want * d[2]};
        const bool inside = std::fabs(at[0]) < 0.99 && std::fabs(at[1]) < 0.99;
        const bool outside = std::fabs(at[0]) > 1.01 || std::fabs(at[1]) > 1.01;
        if (inside) {
          ++hits;
          EXPECT_NEAR(ref.depth[i], want, 1e-13 * want) << "pixel " << x << "," << y << " z " << z;
          EXPECT_EQ(ref.instance_id[i], 0u);
          EXPECT_TRUE(ref.primitive_id[i] == 0u || ref.primitive_id[i] == 1u) << ref.primitive_id[i];
        } else if (outside) {
          ++misses;
          EXPECT_TRUE(std::isinf(ref.depth[i])) << "pixel " << x << "," << y << ": " << ref.depth[i];
          EXPECT_EQ(ref.instance_id[i], kMiss);
          EXPECT_EQ(ref.primitive_id[i], kMiss);
        }
      }
    EXPECT_GT(hits, 12);
    EXPECT_GT(misses, 30);
  }
}

}  // namespace
}  // namespace rayfold
