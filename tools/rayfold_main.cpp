// rayfold: the command-line tool. `rayfold render` traces primary rays and
// writes the hit info; `rayfold info` describes a scene.
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <new>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "../host/atomic_file.h"
#include "../host/errors.h"
#include "../host/gltf_loader.h"
#include "../host/image_output.h"
#include "../host/renderer.h"
#include "cli_args.h"

#ifndef RAYFOLD_DEFAULT_SCENE
#define RAYFOLD_DEFAULT_SCENE "scenes/atrium.glb"
#endif

namespace rayfold {
namespace {

using Clock = std::chrono::steady_clock;

const char* kUsage =
    "usage: rayfold <command> [options]\n"
    "\n"
    "commands:\n"
    "  render [SCENE]   trace primary rays and write the hit info\n"
    "  info SCENE       meshes, instances, triangles and bounds of a scene\n"
    "\n"
    "`rayfold <command> --help` describes a command. SCENE is a .gltf or .glb file;\n"
    "without it, render uses the bundled default scene.\n"
    "exit codes: 0 success, 2 bad input or usage, 3 runtime failure\n";

const char* kRenderUsage =
    "usage: rayfold render [SCENE] [options]\n"
    "\n"
    "  --size WxH             image size (default 1280x720)\n"
    "  --eye X,Y,Z            camera position         } without these, the file's\n"
    "  --look-at X,Y,Z        point looked at         } camera, else a view that\n"
    "  --up X,Y,Z             up direction (0,1,0)    } frames the whole scene\n"
    "  --vfov DEG             vertical field of view (default: the file's, else 60)\n"
    "  --backend opencl|cpu   OpenCL device (default) or the CPU reference tracer\n"
    "  --device NAME          OpenCL device whose name contains NAME\n"
    "  --fast                 fast-math kernels (not bit-exact with the CPU reference)\n"
    "  --no-cull              keep instances outside the view in the top-level tree\n"
    "  --threads N            CPU threads for the CPU backend and builds (0 = all)\n"
    "  --frames N             trace N times and report the medians (default 1)\n"
    "  -o, --output F.exr     OpenEXR hit info: Z N.X N.Y N.Z U V InstanceID PrimitiveID\n"
    "  --png F.png            normal-shaded preview, misses black\n"
    "  --stats F.json         phase times and device buffer sizes\n"
    "  -q, --quiet            print nothing but errors\n";

const char* kInfoUsage = "usage: rayfold info SCENE\n\nprints meshes, instances, triangles and bounds\n";

struct RenderArgs {
  std::string scene = RAYFOLD_DEFAULT_SCENE;
  int width = 1280, height = 720;
  std::optional<glm::dvec3> eye, look_at, up;
  std::optional<double> vfov;
  RendererOptions renderer;
  FrameOptions frame;
  int frames = 1;
  std::string exr, png, stats;
  bool quiet = false;
};

std::string with_commas(size_t n) {
  std::string s = std::to_string(n);
  for (int i = static_cast<int>(s.size()) - 3; i > 0; i -= 3) s.insert(static_cast<size_t>(i), ",");
  return s;
}

Scene load_scene(const std::string& path, bool quiet) {
  std::vector<std::string> warnings;
  Scene scene = load_gltf(path, &warnings);
  if (!quiet)
    for (const std::string& w : warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  return scene;
}

RenderArgs parse_render(cli::Args& args) {
  RenderArgs r;
  bool have_scene = false;
  while (!args.done()) {
    const std::string a = args.next();
    if (a == "--help" || a == "-h") {
      std::fputs(kRenderUsage, stdout);
      std::exit(0);
    } else if (a == "--size") {
      cli::parse_size(a, args.value(a), &r.width, &r.height);
    } else if (a == "--eye") {
      r.eye = cli::parse_vec3(a, args.value(a));
    } else if (a == "--look-at") {
      r.look_at = cli::parse_vec3(a, args.value(a));
    } else if (a == "--up") {
      r.up = cli::parse_vec3(a, args.value(a));
    } else if (a == "--vfov") {
      r.vfov = cli::parse_double(a, args.value(a));
    } else if (a == "--backend") {
      const std::string b = args.value(a);
      if (b == "opencl") r.renderer.backend = Backend::opencl;
      else if (b == "cpu") r.renderer.backend = Backend::cpu;
      else throw UsageError("--backend: '" + b + "' is not opencl or cpu");
    } else if (a == "--device") {
      r.renderer.device_hint = args.value(a);
    } else if (a == "--fast") {
      r.renderer.precision = KernelPrecision::fast;
    } else if (a == "--no-cull") {
      r.frame.cull = false;
    } else if (a == "--threads") {
      r.renderer.threads = static_cast<unsigned>(cli::parse_int(a, args.value(a), 0, 1024));
    } else if (a == "--frames") {
      r.frames = cli::parse_int(a, args.value(a), 1, 100000);
    } else if (a == "-o" || a == "--output") {
      r.exr = args.value(a);
    } else if (a == "--png") {
      r.png = args.value(a);
    } else if (a == "--stats") {
      r.stats = args.value(a);
    } else if (a == "-q" || a == "--quiet") {
      r.quiet = true;
    } else if (!a.empty() && a[0] == '-') {
      throw UsageError("render: unknown option '" + a + "' (see rayfold render --help)");
    } else if (!have_scene) {
      r.scene = a;
      have_scene = true;
    } else {
      throw UsageError("render: more than one scene given ('" + r.scene + "' and '" + a + "')");
    }
  }
  if (r.eye.has_value() != r.look_at.has_value()) throw UsageError("--eye and --look-at go together");
  return r;
}

void write_stats(const std::string& path, const RenderArgs& args, const Scene& scene, const Renderer& renderer,
                 const RenderResult& result, double load_ms) {
  nlohmann::json j;
  j["scene"] = args.scene;
  j["width"] = args.width;
  j["height"] = args.height;
  j["backend"] = args.renderer.backend == Backend::opencl ? "opencl" : "cpu";
  j["device"] = renderer.device_name();
  j["frames"] = result.frames.size();
  j["instances"] = scene.instances.size();
  j["meshes"] = scene.meshes.size();
  j["triangles"] = scene.triangle_count();
  j["rays"] = result.rays;
  j["instances_after_culling"] = result.frame_stats.kept;
  j["times_ms"] = {{"load", load_ms},
                   {"blas_build", renderer.blas_build_ms()},
                   {"cull", result.median.cull_ms},
                   {"tlas_build", result.median.tlas_ms},
                   {"upload", result.median.upload_ms},
                   {"ray_list", result.median.ray_list_ms},
                   {"trace", result.median.trace_ms},
                   {"readback", result.median.readback_ms}};
  j["sah_cost"] = {{"blas", renderer.scene_data().blas.sah_cost}, {"tlas", result.frame_stats.tlas_sah}};
  nlohmann::json buffers = nlohmann::json::object();
  size_t total = 0;
  for (const BufferInfo& b : renderer.device_buffers()) {
    buffers[b.name] = b.bytes;
    total += b.bytes;
  }
  j["device_buffer_bytes"] = buffers;
  j["device_bytes_total"] = total;
  AtomicFile file(path);
  {
    std::ofstream out(file.temp_path());
    out << j.dump(2) << "\n";
    if (!out) throw InputError(path, "cannot write the stats file");
  }
  file.commit();
}

int run_render(cli::Args& args) {
  const RenderArgs r = parse_render(args);
  // Fail on unwritable outputs before any expensive work.
  for (const std::string* out : {&r.exr, &r.png, &r.stats})
    if (!out->empty()) check_writable(*out);

  auto t0 = Clock::now();
  const Scene scene = load_scene(r.scene, r.quiet);
  const double load_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();

  CameraSpec spec = scene.camera ? *scene.camera : frame_bounds(scene.world_bounds());
  if (r.eye) {
    spec.eye = *r.eye;
    spec.look_at = *r.look_at;
    if (!scene.camera) spec.up = glm::dvec3(0.0, 1.0, 0.0);
  }
  if (r.up) spec.up = *r.up;
  if (r.vfov) spec.vfov_degrees = *r.vfov;
  const Camera camera = make_camera(spec, r.width, r.height);

  Renderer renderer(scene, r.renderer);
  const RenderResult result = renderer.render(camera, r.frames, r.frame);

  if (!r.exr.empty()) write_exr(r.exr, result.hits, r.width, r.height);
  if (!r.png.empty()) write_png(r.png, result.hits, r.width, r.height);
  if (!r.stats.empty()) write_stats(r.stats, r, scene, renderer, result, load_ms);

  if (!r.quiet) {
    const FrameTimes& m = result.median;
    const double mrays = result.rays / (m.trace_ms * 1e3);
    std::printf("rayfold render  %s  %dx%d\n", r.scene.c_str(), r.width, r.height);
    std::printf("  %-12s %s\n", "device", renderer.device_name().c_str());
    std::printf("  %-12s %s instances, %s meshes, %s triangles (%s stored)\n", "scene",
                with_commas(scene.instances.size()).c_str(), with_commas(scene.meshes.size()).c_str(),
                with_commas(scene.triangle_count()).c_str(), with_commas(scene.unique_triangle_count()).c_str());
    std::printf("  %-12s %9.2f ms   (SAH cost %.1f, depth %d)\n", "BLAS build", renderer.blas_build_ms(),
                renderer.scene_data().blas.sah_cost, renderer.scene_data().blas.max_depth);
    std::printf("  %-12s %9.2f ms   (%zu of %zu instances after culling, SAH cost %.1f)\n", "TLAS build",
                m.cull_ms + m.tlas_ms, result.frame_stats.kept, result.frame_stats.candidates,
                result.frame_stats.tlas_sah);
    std::printf("  %-12s %9.2f ms   (median of %zu frames)\n", "trace", m.trace_ms, result.frames.size());
    std::printf("  %-12s %9.2f\n", "Mrays/s", mrays);
    if (!r.exr.empty()) std::printf("  wrote %s\n", r.exr.c_str());
    if (!r.png.empty()) std::printf("  wrote %s\n", r.png.c_str());
    if (!r.stats.empty()) std::printf("  wrote %s\n", r.stats.c_str());
  }
  return 0;
}

int run_info(cli::Args& args) {
  std::string path;
  while (!args.done()) {
    const std::string a = args.next();
    if (a == "--help" || a == "-h") {
      std::fputs(kInfoUsage, stdout);
      return 0;
    }
    if (!a.empty() && a[0] == '-') throw UsageError("info: unknown option '" + a + "'");
    if (!path.empty()) throw UsageError("info: more than one scene given");
    path = a;
  }
  if (path.empty()) throw UsageError("info: no scene given (usage: rayfold info SCENE)");
  const Scene scene = load_scene(path, false);
  const Aabb b = scene.world_bounds();
  std::printf("%s\n", path.c_str());
  std::printf("  meshes      %s\n", with_commas(scene.meshes.size()).c_str());
  std::printf("  instances   %s\n", with_commas(scene.instances.size()).c_str());
  std::printf("  triangles   %s rendered, %s stored\n", with_commas(scene.triangle_count()).c_str(),
              with_commas(scene.unique_triangle_count()).c_str());
  if (b.empty()) std::printf("  bounds      (empty)\n");
  else
    std::printf("  bounds      (%g, %g, %g) .. (%g, %g, %g)\n", b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z);
  if (scene.camera)
    std::printf("  camera      eye (%g, %g, %g), looking at (%g, %g, %g), vfov %g\n", scene.camera->eye.x,
                scene.camera->eye.y, scene.camera->eye.z, scene.camera->look_at.x, scene.camera->look_at.y,
                scene.camera->look_at.z, scene.camera->vfov_degrees);
  return 0;
}

int run(int argc, char** argv) {
  if (argc < 2) {
    std::fputs(kUsage, stderr);
    return 2;
  }
  const std::string command = argv[1];
  cli::Args args(argc, argv, 2);
  if (command == "--help" || command == "-h" || command == "help") {
    std::fputs(kUsage, stdout);
    return 0;
  }
  if (command == "render") return run_render(args);
  if (command == "info") return run_info(args);
  throw UsageError("unknown command '" + command + "' (see rayfold --help)");
}

}  // namespace
}  // namespace rayfold

int main(int argc, char** argv) {
  using namespace rayfold;
  try {
    return run(argc, argv);
  } catch (const InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const UsageError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  } catch (const RuntimeFailure& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 3;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "error: out of host memory\n");
    return 3;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 3;
  }
}
