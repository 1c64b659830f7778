// libFuzzer target: arbitrary bytes as a glTF file (.gltf or .glb), through
// the loader, the bottom- and top-level builds and tiny traces. Bad input must
// end in InputError (also for an unusable camera), never a crash or a
// sanitizer report. Every accepted input must also keep rayfold's
// invariants, and a broken one aborts with what differed:
//  - folded (xy) = unfolded, on the CPU reference;
//  - the OpenCL single-ray and tile kernels = the CPU reference, folded too;
//  - ray queries from anywhere (the single-ray query kernel through the
//    8-wide whole trees) = the CPU reference's, every field;
//  - the scene and camera scaled by a power of two 2^k (k from the input's
//    hash, in -100..100, kept inside the float range) give the same ids,
//    barycentrics and normals, and depths times 2^k (where the unscaled
//    depth is a normal float; a smaller one has lost bits already).
#include <unistd.h>

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "fold/ray_list.h"
#include "opencl/cl_query_tracer.h"
#include "opencl/cl_tracer.h"
#include "pipeline/pipeline.h"
#include "rays/ray_queries.h"
#include "scene/gltf_loader.h"
#include "util/errors.h"
#include "util/span.h"

namespace {

using namespace rayfold;
using namespace rayfold::core;

const std::string& scratch_path() {
  static const std::string path = "/tmp/rayfold_fuzz_" + std::to_string(::getpid()) + ".gltf";
  return path;
}

// The input being run: a broken invariant saves it as invariant-<hash>
// (libFuzzer's own crash file was not always written for an abort).
const uint8_t* g_data = nullptr;
size_t g_size = 0;
uint64_t hash(const uint8_t* data, size_t size);

[[noreturn]] void fail(const char* what, size_t pixel, const rf_pixel_hit& a, const rf_pixel_hit& b) {
  char name[64];
  std::snprintf(name, sizeof name, "invariant-%016llx", static_cast<unsigned long long>(hash(g_data, g_size)));
  if (std::FILE* f = std::fopen(name, "wb")) {
    std::fwrite(g_data, 1, g_size, f);
    std::fclose(f);
  }
  std::fprintf(stderr, "fuzz: input saved as %s\n", name);
  std::fprintf(stderr,
               "fuzz: %s at pixel %zu: z %a / %a, n (%a %a %a) / (%a %a %a), uv (%a %a) / (%a %a), "
               "instance %u / %u, primitive %u / %u\n",
               what, pixel, a.z, b.z, a.nx, a.ny, a.nz, b.nx, b.ny, b.nz, a.u, a.v, b.u, b.v, a.instance, b.instance,
               a.primitive, b.primitive);
  std::abort();
}

void expect_same(const char* what, ConstSpan<rf_pixel_hit> a, ConstSpan<rf_pixel_hit> b) {
  for (size_t i = 0; i < a.size(); ++i)
    if (std::memcmp(&a[i], &b[i], sizeof(rf_pixel_hit)) != 0) fail(what, i, a[i], b[i]);
}

// One OpenCL device and tracer for the whole run: building the kernels per
// input would cost more than the input.
ClTracer& tracer() {
  static ClDevice device;
  static ClTracer t(device);
  return t;
}

// Renders like Pipeline does for OpenCL, with both kernels.
void check_opencl(const Scene& scene, const SceneData& data, const Camera& camera,
                  ConstSpan<rf_pixel_hit> reference) {
  const size_t pixels = static_cast<size_t>(camera.width) * camera.height;
  tracer().upload_scene(data, max_tlas_nodes(data), max_tlas_items(data), pixels, pixels);
  for (Fold fold : {Fold::none, Fold::xy}) {
    const RayList rays = make_ray_list(camera.params, fold);
    FrameOptions options;
    options.fold = fold;
    const Frame frame = build_frame(scene, data, camera, rays, options);
    tracer().upload_frame(frame);
    tracer().upload_rays(rays);
    for (KernelKind kernel : {KernelKind::single, KernelKind::tile}) {
      std::vector<rf_pixel_hit> hits(pixels);
      tracer().bind_output(hits.data(), pixels);
      tracer().trace(frame_camera(camera, frame), kernel);
      tracer().read_hits(hits.data(), pixels);
      const std::string what = std::string("OpenCL ") + kernel_name(kernel) + (fold == Fold::xy ? " folded" : "") +
                               " differs from the CPU reference";
      expect_same(what.c_str(), reference, hits);
    }
  }
  // The same view twice in one aligned pass, folded: 8 transform groups,
  // each copy the reference's bits.
  tracer().upload_scene(data, max_tlas_nodes(data, 8), max_tlas_items(data, 8), pixels, 2 * pixels);
  const RayList rays = make_ray_list(camera.params, Fold::xy);
  FrameOptions options;
  options.fold = Fold::xy;
  const Frame frame = build_frame(scene, data, std::vector<Camera>{camera, camera}, rays, options);
  tracer().upload_frame(frame);
  tracer().upload_rays(rays);
  std::vector<rf_pixel_hit> hits(2 * pixels);
  tracer().bind_output(hits.data(), hits.size());
  tracer().trace(frame_camera(camera, frame), KernelKind::tile);
  tracer().read_hits(hits.data(), hits.size());
  for (int v = 0; v < 2; ++v)
    expect_same("OpenCL tile, two aligned views, differs from the CPU reference", reference,
                std::vector<rf_pixel_hit>(hits.begin() + v * pixels, hits.begin() + (v + 1) * pixels));
}

// Rays from the bounds' corners, its centre and the eye toward points of
// the bounds (a step of 5/7 of it per ray, wrapping), through the
// single-ray query kernel as Pipeline::intersect drives it, against the
// CPU reference's answers.
void check_queries(const Scene& scene, Pipeline& reference, const CameraSpec& spec, uint64_t seed) {
  const Aabb b = scene.world_bounds();
  if (b.empty()) return;
  std::vector<float> o, d;
  for (int i = 0; i < 48; ++i) {
    glm::vec3 from = i < 8 ? glm::vec3(i & 1 ? b.hi.x : b.lo.x, i & 2 ? b.hi.y : b.lo.y, i & 4 ? b.hi.z : b.lo.z)
                           : i < 16 ? 0.5f * (b.lo + b.hi)
                                    : glm::vec3(spec.eye);
    const float f = static_cast<float>((seed + 5u * i) % 7u) / 7.0f, g = static_cast<float>((seed + 3u * i) % 11u) / 11.0f;
    const glm::vec3 to = b.lo + glm::vec3(f, g, 1.0f - f) * (b.hi - b.lo);
    glm::vec3 dir = to - from;
    if (!(glm::length(dir) > 0.0f)) dir = glm::vec3(0.3f, -1.0f, 0.2f);
    o.insert(o.end(), {from.x, from.y, from.z});
    d.insert(d.end(), {dir.x, dir.y, dir.z});
  }
  const size_t n = o.size() / 3;
  std::vector<rf_pixel_hit> want(n), got(n);
  try {
    reference.intersect(o.data(), d.data(), n, 0.0f, INFINITY, false, FrameOptions{}, want.data());
  } catch (const InputError&) {
    return;  // rays beyond the supported range
  }
  const SceneData& data = reference.scene_data();
  tracer().upload_scene(data, max_tlas_nodes(data), max_tlas_items(data), 1, 1);
  const Wide8Trees trees = build_query_trees(data);
  ClQueryTracer queries(tracer());
  queries.upload_query_trees(trees);
  const Frame frame =
      build_query_frame(scene, data, check_query_rays(o.data(), d.data(), n, 0.0f, INFINITY), FrameOptions{}, &trees);
  queries.upload_frame(frame);
  std::vector<rf_query_ray> records;
  to_trace_space(o.data(), d.data(), 0, n, 0.0f, INFINITY, frame, records);
  ClQueryTracer::QueryRays rays;
  rays.records = &records;
  rays.count = n;
  queries.trace_queries(rays, false, 0, got.data());
  expect_same("OpenCL ray queries differ from the CPU reference", want, got);
}

// The largest magnitude among the scene's world bounds and the eye; 0 when
// empty.
double world_magnitude(const Scene& scene, const CameraSpec& spec) {
  double m = std::max({std::fabs(spec.eye.x), std::fabs(spec.eye.y), std::fabs(spec.eye.z), std::fabs(spec.look_at.x),
                       std::fabs(spec.look_at.y), std::fabs(spec.look_at.z)});
  const Aabb b = scene.world_bounds();
  if (!b.empty())
    for (int k = 0; k < 3; ++k) m = std::max({m, std::fabs(double(b.lo[k])), std::fabs(double(b.hi[k]))});
  return m;
}

void check_scaled(const Scene& scene, const CameraSpec& spec, ConstSpan<rf_pixel_hit> reference, int k) {
  Scene scaled = scene;
  for (Instance& inst : scaled.instances) inst.world_from_object = uniform_scale(k) * inst.world_from_object;
  CameraSpec s = spec;
  s.eye = std::ldexp(1.0, k) * spec.eye;
  s.look_at = std::ldexp(1.0, k) * spec.look_at;
  PipelineOptions options;
  options.backend = Backend::cpu;
  options.threads = 1;
  Pipeline renderer(scaled, options);
  const Camera camera = make_camera(s, 9, 7);
  const HitBuffer hits = renderer.render(camera, 1, FrameOptions{Fold::none}).hits;
  for (size_t i = 0; i < hits.size(); ++i) {
    rf_pixel_hit expected = reference[i];
    expected.z = std::ldexp(expected.z, k);
    // A depth below 2^-126 world units is a subnormal float that has already
    // lost bits, or 0 below 2^-149; scaled up it cannot get them back. Every
    // other channel still must agree.
    rf_pixel_hit actual = hits[i];
    if (std::fabs(reference[i].z) < FLT_MIN) expected.z = actual.z;
    if (std::memcmp(&expected, &actual, sizeof(rf_pixel_hit)) != 0) {
      char what[64];
      std::snprintf(what, sizeof what, "scaled by 2^%d, differs from unscaled (depth scaled)", k);
      fail(what, i, expected, actual);
    }
  }
}

uint64_t hash(const uint8_t* data, size_t size) {
  uint64_t h = 1469598103934665603ull;
  for (size_t i = 0; i < size; ++i) h = (h ^ data[i]) * 1099511628211ull;
  return h;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  g_data = data;
  g_size = size;
  {
    std::FILE* f = std::fopen(scratch_path().c_str(), "wb");
    if (!f) return 0;
    std::fwrite(data, 1, size, f);
    std::fclose(f);
  }
  try {
    const Scene scene = load_gltf(scratch_path());
    if (scene.triangle_count() > 100000) return 0;  // keep each input fast
    PipelineOptions options;
    options.backend = Backend::cpu;
    options.threads = 1;
    Pipeline renderer(scene, options);
    const CameraSpec spec = scene.camera ? *scene.camera : frame_bounds(scene.world_bounds());
    const Camera camera = make_camera(spec, 9, 7);
    const RenderResult none = renderer.render(camera, 1, FrameOptions{Fold::none});
    const RenderResult xy = renderer.render(camera, 1, FrameOptions{Fold::xy});
    expect_same("folded render differs from unfolded", none.hits, xy.hits);
    check_opencl(scene, renderer.scene_data(), camera, none.hits);
    check_queries(scene, renderer, spec, hash(data, size));
    // A power of two that keeps every world coordinate a normal float with
    // room to spare (the supported range, docs/exactness.md).
    // The file's animations posed at a time from the input's hash: loading
    // must hold up, and the fold stays lossless.
    LoadOptions posed;
    posed.time = static_cast<double>(hash(data, size) % 4000) / 1000.0 - 1.0;
    const Scene animated = load_gltf(scratch_path(), nullptr, posed);
    if (animated.triangle_count() <= 100000) {
      Pipeline r2(animated, options);
      const Camera c2 = make_camera(animated.camera ? *animated.camera : frame_bounds(animated.world_bounds()), 9, 7);
      expect_same("posed: folded render differs from unfolded", r2.render(c2, 1, FrameOptions{Fold::none}).hits,
                  r2.render(c2, 1, FrameOptions{Fold::xy}).hits);
    }
    const double magnitude = world_magnitude(scene, spec);
    if (magnitude > 0.0 && std::isfinite(magnitude)) {
      const int top = std::ilogb(magnitude);
      const int lo = std::max(-100, -100 - top), hi = std::min(100, 100 - top);
      if (lo <= hi) check_scaled(scene, spec, none.hits, lo + static_cast<int>(hash(data, size) % (hi - lo + 1)));
    }
  } catch (const InputError&) {
  }
  return 0;
}
