#include "test_util.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <sstream>
#include <tuple>

#include <unistd.h>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>

#include "fixtures/scene_gen.h"
#include "fold/depth_xform.h"
#include "rf_trace.h"
#include "scene/animation.h"
#include "scene/gltf_loader.h"

namespace rayfold::core::testing {

uint64_t Rng::next() {
  uint64_t z = (s_ += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

double Rng::uniform(double lo, double hi) { return lo + (hi - lo) * (next() >> 11) * 0x1p-53; }

namespace {

// Every instance with its object_from_trace rows (the mesh's own
// coordinates rather than the trees' power-of-two-scaled ones: the same
// geometry written another way; scaling by powers of two is exact, so the
// bits must agree with every tracer's), and every mesh's triangles.
struct BruteScene {
  std::vector<rf_instance> insts;
  std::vector<std::vector<rf_tri>> mesh_tris;
};

BruteScene brute_scene(const Scene& scene, const SceneData& data, const Xform& world_from_trace) {
  BruteScene b;
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    if (!data.renderable[i]) continue;
    rf_instance inst{};
    Xform object_from_world;
    if (!affine_inverse(scene.instances[i].world_from_object, &object_from_world)) continue;
    to_rows3x4(object_from_world * world_from_trace, inst.tree_from_trace);
    inst.instance_id = static_cast<uint32_t>(i);
    b.insts.push_back(inst);
  }
  b.mesh_tris.resize(scene.meshes.size());
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const Mesh& mesh = scene.meshes[m];
    for (size_t t = 0; t < mesh.triangle_count(); ++t) {
      rf_tri tri{};
      for (int k = 0; k < 3; ++k) {
        tri.v0[k] = mesh.positions[mesh.indices[3 * t]][k];
        tri.v1[k] = mesh.positions[mesh.indices[3 * t + 1]][k];
        tri.v2[k] = mesh.positions[mesh.indices[3 * t + 2]][k];
      }
      tri.prim = static_cast<uint32_t>(t);
      rf_tri_set_normal(&tri);
      b.mesh_tris[m].push_back(tri);
    }
  }
  return b;
}

// The closest hit beyond tmin (best starts as the caller's bound) over
// every triangle, each instance's ray from make_ray(instance), written out
// with len_d and the G-buffer's normal; returns the hit triangle (null on a
// miss).
template <class MakeRay>
const rf_tri* brute_closest(const BruteScene& b, const Scene& scene, const SceneData& data, float tmin, rf_hit best,
                            float len_d, MakeRay&& make_ray, rf_pixel_hit* out) {
  const rf_tri* best_tri = nullptr;
  for (const rf_instance& inst : b.insts) {
    const rf_ray r = make_ray(inst);
    for (const rf_tri& tri : b.mesh_tris[scene.instances[inst.instance_id].mesh]) {
      float t, u, v;
      if (rf_intersect_triangle(&tri, &r, &t, &u, &v) && t > tmin &&
          rf_hit_is_closer(t, inst.instance_id, tri.prim, &best)) {
        best.t = t;
        best.u = u;
        best.v = v;
        best.instance = inst.instance_id;
        best.prim = tri.prim;
        best_tri = &tri;
      }
    }
  }
  // rf_write_pixel finds the triangle through an index; hand it this one.
  best.tri = 0;
  rf_write_pixel(out, &best, len_d, 1.0f, best_tri, data.normal_xforms.data(), 0u);
  return best_tri;
}

}  // namespace

std::vector<rf_pixel_hit> brute_force(const Scene& scene, const SceneData& data, const Camera& camera,
                                      bool exact_depth) {
  const rf_camera& cam = camera.params;
  const BruteScene b = brute_scene(scene, data, camera.world_from_camera);
  // The exact depth in camera space and object space, which differ from
  // trace and tree space by powers of two: the same bits (kernels/rf_depth.h).
  std::vector<rf_depth_xform> depth_xforms(exact_depth ? scene.instances.size() + 1 : 0);
  if (exact_depth) depth_xforms[0] = make_depth_xform(Xform(1.0), camera, 0);
  for (const rf_instance& inst : exact_depth ? b.insts : std::vector<rf_instance>{}) {
    Xform object_from_world;
    affine_inverse(scene.instances[inst.instance_id].world_from_object, &object_from_world);
    depth_xforms[1 + inst.instance_id] = make_depth_xform(object_from_world * camera.world_from_camera, camera, 0);
  }
  const rf_depth_table depths{depth_xforms.data(), static_cast<uint32_t>(scene.instances.size())};
  std::vector<rf_pixel_hit> out(static_cast<size_t>(cam.width) * cam.height);
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      // Orthographic: (px, py) is the ray's origin on the image plane.
      const float px = cam.scale_x * (static_cast<float>(2 * x + cam.kx0) + cam.frac_x);
      const float py = cam.scale_y * (static_cast<float>(cam.ky0 - 2 * y) + cam.frac_y);
      const float dx = cam.ortho ? 0.0f : px, dy = cam.ortho ? 0.0f : py, dz = -1.0f;
      rf_hit best;
      rf_hit_reset(&best);
      const float len_d = cam.ortho ? 1.0f : RF_SQRT(dx * dx + dy * dy + dz * dz);
      rf_pixel_hit& px_out = out[static_cast<size_t>(y) * cam.width + x];
      const rf_tri* tri = brute_closest(b, scene, data, 0.0f, best, len_d, [&](const rf_instance& inst) {
        rf_ray r;
        if (cam.ortho)
          rf_ray_to_object_from(&r, inst.tree_from_trace, px, py, dx, dy, dz);
        else
          rf_ray_to_object(&r, inst.tree_from_trace, dx, dy, dz);
        return r;
      }, &px_out);
      if (tri && exact_depth) px_out.z = rf_pixel_depth(&depths, 0, px_out.instance, tri, &cam, x, y, 1.0f, px_out.z);
    }
  return out;
}

std::vector<rf_pixel_hit> brute_force_rays(const Scene& scene, const SceneData& data, const float* origins,
                                           const float* directions, size_t n, float tmin, float tmax) {
  const BruteScene b = brute_scene(scene, data, Xform(1.0));
  std::vector<rf_pixel_hit> out(n);
  for (size_t q = 0; q < n; ++q) {
    const float* o = origins + 3 * q;
    const float* d = directions + 3 * q;
    rf_hit best;
    rf_hit_reset(&best);
    best.t = tmax;
    brute_closest(b, scene, data, tmin, best, 1.0f, [&](const rf_instance& inst) {
      rf_ray r;
      rf_ray_to_object_at(&r, inst.tree_from_trace, o[0], o[1], o[2], d[0], d[1], d[2]);
      return r;
    }, &out[q]);
  }
  return out;
}

std::string compare_hits(ConstSpan<rf_pixel_hit> expected, ConstSpan<rf_pixel_hit> actual,
                         int width) {
  if (expected.size() != actual.size()) return "sizes differ";
  size_t bad = 0;
  std::ostringstream first;
  for (size_t i = 0; i < expected.size(); ++i) {
    if (std::memcmp(&expected[i], &actual[i], sizeof(rf_pixel_hit)) == 0) continue;
    if (bad++ == 0) {
      const rf_pixel_hit &e = expected[i], &a = actual[i];
      first.precision(9);
      first << "pixel (" << i % width << ", " << i / width << "): expected z=" << e.z << " n=(" << e.nx << "," << e.ny
            << "," << e.nz << ") uv=(" << e.u << "," << e.v << ") inst=" << e.instance << " prim=" << e.primitive
            << "; got z=" << a.z << " n=(" << a.nx << "," << a.ny << "," << a.nz << ") uv=(" << a.u << "," << a.v
            << ") inst=" << a.instance << " prim=" << a.primitive;
    }
  }
  if (bad == 0) return "";
  return std::to_string(bad) + " of " + std::to_string(expected.size()) + " pixels differ; first: " + first.str();
}

CameraSpec random_camera(Rng& rng, const Aabb& b) {
  const glm::dvec3 lo(b.lo), hi(b.hi), size = hi - lo;
  CameraSpec c;
  c.eye = lo - 0.3 * size + glm::dvec3(rng.uniform(0, 1), rng.uniform(0, 1), rng.uniform(0, 1)) * 1.6 * size;
  glm::dvec3 dir;
  const int kind = rng.below(4);
  if (kind == 0) {  // along an axis, exactly
    dir = glm::dvec3(0.0);
    dir[rng.below(3)] = rng.below(2) ? 1.0 : -1.0;
  } else if (kind == 1) {  // at the middle of the scene
    dir = (lo + hi) * 0.5 - c.eye;
  } else {
    dir = glm::dvec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
  }
  if (glm::length(dir) < 1e-6) dir = glm::dvec3(0.0, 0.0, -1.0);
  c.look_at = c.eye + dir;
  // Roll: any up vector not parallel to the view.
  for (;;) {
    c.up = glm::dvec3(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    if (rng.below(3) == 0) c.up = glm::dvec3(0.0, 1.0, 0.0);
    if (glm::length(glm::cross(c.up, dir)) > 1e-3 * glm::length(c.up) * glm::length(dir)) break;
  }
  c.vfov_degrees = rng.uniform(20.0, 110.0);
  return c;
}

CameraSpec random_ortho_camera(Rng& rng, const Aabb& bounds) {
  CameraSpec spec = random_camera(rng, bounds);
  spec.orthographic = true;
  spec.ymag = 0.5 * glm::length(glm::dvec3(bounds.hi - bounds.lo)) * rng.uniform(0.2, 1.0);
  // From outside: the image plane starts behind everything.
  const glm::dvec3 centre = 0.5 * (glm::dvec3(bounds.lo) + glm::dvec3(bounds.hi));
  const glm::dvec3 dir = glm::normalize(spec.look_at - spec.eye);
  spec.eye = centre - dir * glm::length(glm::dvec3(bounds.hi - bounds.lo));
  spec.look_at = centre;
  return spec;
}

Scene random_scene(Rng& rng, int meshes, int instances, int triangles_per_mesh) {
  Scene s;
  for (int m = 0; m < meshes; ++m) {
    Mesh mesh;
    const glm::vec3 centre(rng.uniformf(-1, 1), rng.uniformf(-1, 1), rng.uniformf(-1, 1));
    for (int t = 0; t < triangles_per_mesh; ++t) {
      const glm::vec3 c = centre + glm::vec3(rng.uniformf(-1, 1), rng.uniformf(-1, 1), rng.uniformf(-1, 1));
      const float r = rng.uniformf(0.05f, 0.6f);
      const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
      for (int k = 0; k < 3; ++k)
        mesh.positions.push_back(c + r * glm::vec3(rng.uniformf(-1, 1), rng.uniformf(-1, 1), rng.uniformf(-1, 1)));
      if (rng.below(20) == 0) mesh.positions[base + 2] = mesh.positions[base + 1];  // zero area
      mesh.indices.insert(mesh.indices.end(), {base, base + 1, base + 2});
    }
    s.meshes.push_back(std::move(mesh));
  }
  for (int i = 0; i < instances; ++i) {
    Instance inst;
    inst.mesh = static_cast<uint32_t>(rng.below(meshes));
    Xform m = glm::translate(Xform(1.0), glm::dvec3(rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(-4, 4)));
    m = glm::rotate(m, rng.uniform(0, 6.3), glm::normalize(glm::dvec3(rng.uniform(-1, 1), rng.uniform(-1, 1), 0.7)));
    glm::dvec3 scale(rng.uniform(0.3, 2.0), rng.uniform(0.3, 2.0), rng.uniform(0.3, 2.0));
    if (rng.below(3) == 0) scale[rng.below(3)] *= -1.0;  // a mirror
    inst.world_from_object = glm::scale(m, scale);
    s.instances.push_back(inst);
  }
  return s;
}

ThreeWays::ThreeWays(const Scene& scene) {
  PipelineOptions o;
  o.backend = Backend::cpu;
  // differences() may animate: the moving instances keep their own trees.
  o.merge.dynamic = animated_instances(scene.instances.size());
  cpu = std::make_unique<Pipeline>(scene, o);
  o.backend = Backend::opencl;
  o.kernel = Kernel::single;
  single = std::make_unique<Pipeline>(scene, o);
  o.kernel = Kernel::tile;
  tile = std::make_unique<Pipeline>(scene, o);
}

HitBuffer ThreeWays::reference(const Camera& cam, int animate_frame, const FrameOptions& base) {
  FrameOptions none = base;
  none.fold = Fold::none;
  none.animate_frame = animate_frame;
  return cpu->render(cam, 1, none).hits;
}

std::string ThreeWays::differences(const Camera& cam, int animate_frame, const FrameOptions& base) {
  const HitBuffer ref = reference(cam, animate_frame, base);
  std::string out;
  for (Fold f : kAllFolds) {
    FrameOptions o = base;
    o.animate_frame = animate_frame;
    o.fold = f;
    for (auto [name, r] : {std::pair<const char*, Pipeline*>{"single", single.get()}, {"tile", tile.get()}}) {
      const std::string d = compare_hits(ref, r->render(cam, 1, o).hits, cam.width);
      if (!d.empty()) out += std::string(name) + " fold " + fold_name(f) + ": " + d + "\n";
    }
  }
  return out;
}

ClDevice& test_device() {
  static ClDevice device;
  return device;
}

std::string shared_scenes_dir() {
  namespace fs = std::filesystem;
  if (const char* env = std::getenv("RAYFOLD_SCENES_DIR")) return fs::is_directory(env) ? env : "";
  const fs::path p = fs::path(RAYFOLD_SOURCE_DIR) / ".." / "shared" / "scenes";
  return fs::is_directory(p) ? p.lexically_normal().string() : "";
}

Scene generated_atrium(uint64_t seed, int objects, size_t triangle_budget) {
  GenOptions gen;
  gen.seed = seed;
  gen.objects = objects;
  gen.triangle_budget = triangle_budget;
  return generate_atrium(gen);
}

void move_eye_inside_an_instance(Rng& rng, const Scene& scene, CameraSpec& spec) {
  const Instance& inst = scene.instances[rng.below(static_cast<int>(scene.instances.size()))];
  const Aabb b = transform_bounds_conservative(inst.world_from_object, scene.mesh_bounds(inst.mesh));
  spec.look_at = spec.look_at - spec.eye + glm::dvec3(b.centre());
  spec.eye = glm::dvec3(b.centre());
}

const std::vector<SharedView>& shared_views() {
  static const std::vector<SharedView> views = {
      {"dabrovic_sponza.glb", {0, 3, 0}, {10, 3, 0}},    {"conference.glb", {330, 300, -300}, {1000, 200, 0}},
      {"sports_car.glb", {1.8, 0.9, 2.2}, {0, 0.45, 0}}, {"stanford_dragon.glb", {0, 0.13, 0.22}, {0, 0.12, 0}},
      {"armadillo.glb", {0, 20, 170}, {0, 20, 0}},       {"lost_empire.glb", {-10, 20, 40}, {10, 10, 0}},
  };
  return views;
}

int for_each_shared_scene(const std::function<void(const SharedView&, const Scene&)>& fn) {
  const std::string dir = shared_scenes_dir();
  int n = 0;
  if (dir.empty()) return 0;
  for (const SharedView& v : shared_views()) {
    const std::string path = dir + "/" + v.file;
    if (!std::filesystem::exists(path)) continue;
    fn(v, load_gltf(path));
    ++n;
  }
  return n;
}

CameraSpec SharedView::camera() const {
  CameraSpec spec;
  spec.eye = eye;
  spec.look_at = look_at;
  return spec;
}

Mesh unit_triangle() {
  Mesh tri;
  tri.positions = {{-1.0f, -1.0f, 0.0f}, {1.0f, -1.0f, 0.0f}, {0.0f, 1.0f, 0.0f}};
  tri.indices = {0, 1, 2};
  return tri;
}

Mesh closed_cube(int n) {
  Mesh m;
  std::map<std::tuple<int, int, int>, uint32_t> index;
  auto vertex = [&](int i, int j, int k) {
    auto [it, fresh] = index.try_emplace({i, j, k}, static_cast<uint32_t>(m.positions.size()));
    if (fresh) m.positions.emplace_back(-1.0f + 2.0f * i / n, -1.0f + 2.0f * j / n, -1.0f + 2.0f * k / n);
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side <= 1; ++side)
      for (int a = 0; a < n; ++a)
        for (int b = 0; b < n; ++b) {
          auto at = [&](int da, int db) {
            int c[3];
            c[axis] = side * n;
            c[(axis + 1) % 3] = a + da;
            c[(axis + 2) % 3] = b + db;
            return vertex(c[0], c[1], c[2]);
          };
          const uint32_t v00 = at(0, 0), v10 = at(1, 0), v11 = at(1, 1), v01 = at(0, 1);
          if ((a + b) % 2)
            m.indices.insert(m.indices.end(), {v00, v10, v11, v00, v11, v01});
          else
            m.indices.insert(m.indices.end(), {v00, v10, v01, v10, v11, v01});
        }
  return m;
}

Mesh wound_box(bool inward, const glm::vec3& size) {
  Mesh m = closed_cube(4);
  for (glm::vec3& p : m.positions) p *= size;
  for (size_t t = 0; t < m.triangle_count(); ++t) {
    uint32_t* i = &m.indices[3 * t];
    const glm::vec3 a = m.positions[i[0]], b = m.positions[i[1]], c = m.positions[i[2]];
    const float facing = glm::dot(glm::cross(b - a, c - a), a + b + c);
    if ((facing < 0.0f) != inward) std::swap(i[1], i[2]);
  }
  return m;
}

std::unique_ptr<Pipeline> cpu_pipeline(const Scene& scene) {
  PipelineOptions o;
  o.backend = Backend::cpu;
  return std::make_unique<Pipeline>(scene, o);
}

bool same_bits(const glm::dvec3& a, const glm::dvec3& b) { return std::memcmp(&a, &b, sizeof a) == 0; }

namespace {

// The scratch directories this process made, removed as it exits.
struct ScratchDirs {
  std::mutex lock;
  pid_t owner = ::getpid();
  std::vector<std::filesystem::path> dirs;
  ~ScratchDirs() {
    if (::getpid() != owner) return;
    for (const std::filesystem::path& d : dirs) {
      std::error_code ignored;  // a test that failed may have left it unreadable; nothing to report at exit
      std::filesystem::remove_all(d, ignored);
    }
  }
};

}  // namespace

std::filesystem::path scratch_dir(const std::string& name) {
  static ScratchDirs made;
  const std::filesystem::path d = std::filesystem::temp_directory_path() / (name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(d);
  const std::lock_guard<std::mutex> hold(made.lock);
  if (std::find(made.dirs.begin(), made.dirs.end(), d) == made.dirs.end()) made.dirs.push_back(d);
  return d;
}

}  // namespace rayfold::core::testing
