// Helpers shared by the tests: a brute-force tracer (no trees, no culling),
// random cameras and scenes, bitwise image comparison, the OpenCL device.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "device_layout.h"
#include "fold/frame.h"
#include "opencl/cl_device.h"
#include "pipeline/pipeline.h"
#include "scene/camera.h"
#include "scene/scene.h"
#include "util/span.h"

namespace rayfold::core::testing {

// splitmix64, for reproducible test inputs.
class Rng {
 public:
  explicit Rng(uint64_t seed) : s_(seed) {}
  uint64_t next();
  double uniform(double lo, double hi);
  float uniformf(float lo, float hi) { return static_cast<float>(uniform(lo, hi)); }
  int below(int n) { return static_cast<int>(next() % static_cast<uint64_t>(n)); }

 private:
  uint64_t s_;
};

// Every pixel's closest hit by testing every triangle of every instance with
// the shared triangle test and tie rule: what the trees must reproduce;
// exact_depth: the depth of kernels/rf_depth.h, in object space.
std::vector<rf_pixel_hit> brute_force(const Scene& scene, const SceneData& data, const Camera& camera,
                                      bool exact_depth = false);
// The same for ray queries: n world-space rays (origins, directions n x 3),
// hits with tmin < t <= tmax, z = t (Pipeline::intersect's answers).
std::vector<rf_pixel_hit> brute_force_rays(const Scene& scene, const SceneData& data, const float* origins,
                                           const float* directions, size_t n, float tmin, float tmax);

// "" when equal bit for bit, else a description of the first difference and
// the number of differing pixels.
std::string compare_hits(ConstSpan<rf_pixel_hit> expected, ConstSpan<rf_pixel_hit> actual, int width);

// A camera somewhere in or around the bounds, looking anywhere, with roll;
// sometimes along an axis, sometimes from inside an object's box.
CameraSpec random_camera(Rng& rng, const Aabb& bounds);
// A random orthographic view from outside the bounds (the image plane
// behind everything), its half-height a random share of their size.
CameraSpec random_ortho_camera(Rng& rng, const Aabb& bounds);

// The scene generator's atrium (tools/fixtures/scene_gen.h) with this seed, object
// count and triangle budget.
Scene generated_atrium(uint64_t seed, int objects, size_t triangle_budget);

// Moves the camera, keeping its direction, to the centre of a random
// instance's box: the eye inside an object.
void move_eye_inside_an_instance(Rng& rng, const Scene& scene, CameraSpec& spec);

// A scene of random triangle soups (including zero-area triangles) placed by
// random affine transforms: rotations, non-uniform scales and mirrors.
Scene random_scene(Rng& rng, int meshes, int instances, int triangles_per_mesh);

// One triangle, (-1, -1, 0), (1, -1, 0), (0, 1, 0), facing +z.
Mesh unit_triangle();

// The surface of an n x n x n lattice cube [-1, 1]^3 with shared vertices, so
// every edge is shared by exactly two triangles: a closed mesh. The diagonals
// alternate so that edges meet at every angle.
Mesh closed_cube(int n);

// closed_cube(4) scaled by `size` about the origin, every triangle wound to
// face outwards (a solid) or inwards (a room seen from inside).
Mesh wound_box(bool inward, const glm::vec3& size = glm::vec3(1.0f));

// A CPU-reference pipeline of the scene (the probes of auto-framing and
// random views take one).
std::unique_ptr<Pipeline> cpu_pipeline(const Scene& scene);

// Whether two points are the same doubles, bit for bit.
bool same_bits(const glm::dvec3& a, const glm::dvec3& b);

inline constexpr Fold kAllFolds[] = {Fold::none, Fold::y, Fold::x, Fold::xy};

// One scene, rendered three ways: the CPU reference, the single-ray kernel
// and the tile kernel (with the instances --animate moves built dynamic).
struct ThreeWays {
  explicit ThreeWays(const Scene& scene);
  // The CPU reference's unfolded render.
  HitBuffer reference(const Camera& cam, int animate_frame = -1, const FrameOptions& base = {});
  // "" when, for every fold mode, the single-ray and tile kernels equal the
  // CPU reference's unfolded render; else every difference found. base: the
  // frame options besides the fold and animation (the exact depth).
  std::string differences(const Camera& cam, int animate_frame = -1, const FrameOptions& base = {});

  std::unique_ptr<Pipeline> cpu, single, tile;
};

// The process-wide OpenCL device (PoCL on CI machines).
ClDevice& test_device();

// <temp>/<name>_<pid>, created; removed with what it holds when the process
// that made it exits normally (every ctest entry is a process of its own),
// so that runs of the suite leave nothing in /tmp. A forked child's exit
// leaves it to its parent.
std::filesystem::path scratch_dir(const std::string& name);

// ../shared/scenes beside the repository, or $RAYFOLD_SCENES_DIR; "" when
// absent.
std::string shared_scenes_dir();

// The suggested views of ../shared/scenes/README.md: a file name and a camera
// looking from `eye` at `look_at` with +y up.
struct SharedView {
  const char* file;
  glm::dvec3 eye, look_at;
  CameraSpec camera() const;
};
const std::vector<SharedView>& shared_views();
// Calls fn for every suggested view whose scene is present, with the loaded
// scene; returns how many were.
int for_each_shared_scene(const std::function<void(const SharedView&, const Scene&)>& fn);

}  // namespace rayfold::core::testing
