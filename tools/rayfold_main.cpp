// rayfold: the command-line tool. `rayfold render` traces primary rays and
// writes the hit info; `rayfold info` describes a scene.
#include <cctype>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <iostream>
#include <new>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "bench.h"
#include "bench_align.h"
#include "camera_list.h"
#include "cli_args.h"
#include "fold/view_passes.h"
#include "progress.h"
#include "reference/hit_compare.h"
#include "renderer.h"
#include "scene/gltf_loader.h"
#include "util/atomic_file.h"
#include "util/errors.h"
#include "util/image_output.h"
#include "util/timer.h"

#ifndef RAYFOLD_VERSION
#define RAYFOLD_VERSION "unknown"
#endif

#ifndef RAYFOLD_DEFAULT_SCENE
#define RAYFOLD_DEFAULT_SCENE "scenes/atrium.glb"
#endif

namespace rayfold::core {
namespace {

// The bundled scene: in the source tree for a build, beside the binary
// (../share/rayfold) once installed.
std::string default_scene() {
  std::error_code ec;
  if (std::filesystem::exists(RAYFOLD_DEFAULT_SCENE, ec)) return RAYFOLD_DEFAULT_SCENE;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const std::filesystem::path installed = exe.parent_path().parent_path() / "share" / "rayfold" / "atrium.glb";
    if (std::filesystem::exists(installed, ec)) return installed.string();
  }
  return RAYFOLD_DEFAULT_SCENE;
}

const char* kUsage =
    "usage: rayfold <command> [options]\n"
    "\n"
    "commands:\n"
    "  render [SCENE]   trace primary rays and write the hit info\n"
    "  info SCENE       meshes, instances, triangles and bounds of a scene\n"
    "  bench [SCENE]    every fold mode on the same camera path: the paper's tables\n"
    "  devices          the OpenCL platforms and devices (--device picks by name)\n"
    "  --version        rayfold's version\n"
    "\n"
    "`rayfold <command> --help` describes a command. SCENE is a .gltf or .glb file;\n"
    "without it, render uses the bundled default scene.\n"
    "exit codes: 0 success, 2 bad input or usage, 3 runtime failure\n";

const char* kDevicesUsage =
    "usage: rayfold devices\n"
    "Lists the OpenCL platforms and devices this machine offers, with their compute units;\n"
    "--device NAME (render, bench) picks the first whose platform or name contains NAME.\n";

const char* kRenderUsage =
    "usage: rayfold render [SCENE] [options]\n"
    "\n"
    "  --size WxH             image size (default 1280x720)\n"
    "  --eye X,Y,Z            camera position         } without these, the file's\n"
    "  --look-at X,Y,Z        point looked at         } camera, else a view that\n"
    "  --up X,Y,Z             up direction (0,1,0)    } frames the whole scene\n"
    "                         (--up alone turns the file's camera)\n"
    "  --vfov DEG             vertical field of view (default: the file's, else 60); a\n"
    "                         perspective view also where the file's camera is orthographic\n"
    "  --ortho YMAG           an orthographic view, YMAG world units above and below the axis\n"
    "  --scene N              the file's scene N (default: its `scene`, else 0)\n"
    "  --camera N             the scene's camera N (default: its first camera,\n"
    "                         perspective or orthographic); `rayfold info` lists both\n"
    "  --time T               the pose of the file's animations at T seconds\n"
    "  --backend opencl|cpu   OpenCL device (default) or the CPU reference tracer\n"
    "  --device NAME          OpenCL device whose name contains NAME\n"
    "  --kernel tile|single|measure|auto  OpenCL kernel: tiles of 256 rays in vector\n"
    "                         lanes, or one ray per work-item; measure: trace the\n"
    "                         first frame with both and keep the faster (auto: tile\n"
    "                         on CPU devices, measure elsewhere); same bits either way;\n"
    "                         orthographic views always trace one ray per work-item\n"
    "  --fast                 fast-math kernels (not bit-exact with the CPU reference)\n"
    "  --fold none|y|x|xy|auto  trace a half (y: left, x: top) or a quarter (xy) of the\n"
    "                         rays, each answering its mirror pixels (default none);\n"
    "                         auto: the fold (and, with --kernel auto, the kernel) the\n"
    "                         cost model predicts fastest from a probe of sampled tiles,\n"
    "                         printed with the predictions (docs/cost_model.md)\n"
    "  --shift SX,SY          off-centre image window, in half image widths/heights;\n"
    "                         only its symmetric part folds\n"
    "  --animate              play the file's animations over --frames (frame f at\n"
    "                         --time + f / --fps); a file without any: move every\n"
    "                         fourth instance every frame\n"
    "  --fps F                frames per second of --animate (default 30)\n"
    "  --compare              also render unfolded, check the two agree bit for bit\n"
    "                         and print them side by side (--fold defaults to xy;\n"
    "                         --fold none has nothing to compare and is refused);\n"
    "                         exit code 3, and no file written, when they differ\n"
    "  --braid N              top level opens the instances' trees into about N items\n"
    "                         per instance, at least 256 (partial re-braiding;\n"
    "                         default 2, 0 = whole instances)\n"
    "  --no-cull              keep instances outside the view in the top-level tree\n"
    "  --threads N            CPU threads for the CPU backend and builds (0 = all)\n"
    "  --frames N             trace N times and report the medians (default 1)\n"
    "  -o, --output F.exr     OpenEXR hit info: Z N.X N.Y N.Z U V InstanceID PrimitiveID;\n"
    "                         a frame field (out/frame_%04d.exr) writes every frame\n"
    "  --png F.png            normal-shaded preview, misses black\n"
    "  --stats F.json         the camera, options, hit and miss counts, phase times, device buffers\n"
    "  --ids F.json           the id manifest: InstanceID -> the file's node name and mesh\n"
    "  --cameras F.json       render every view of a camera list, one output per view\n"
    "                         (-o out/view_%04d.exr); see the README for the format\n"
    "  --stereo B             a parallel-axis stereo pair around the camera, eyes B apart\n"
    "                         along its right vector (outputs NAME-left.exr, NAME-right.exr)\n"
    "  --align N|all|auto     --cameras, --stereo: trace up to N views together (alignment;\n"
    "                         1 = each alone; all, the default: as many as one pass holds,\n"
    "                         32 / the fold's mirrors; auto: as the cost model predicts\n"
    "                         fastest); views with other intrinsics go to other passes;\n"
    "                         every view's bits equal the view alone\n"
    "  -q, --quiet            print nothing but errors and warnings (no table, no\n"
    "                         progress)\n"
    "  -v, --verbose          also the time of every stage, and of every frame\n"
    "Each output's extension must match its kind (.exr, .png, .json), so no two\n"
    "outputs can name the same file.\n";

const char* kBenchUsage =
    "usage: rayfold bench [SCENE] [options]\n"
    "\n"
    "Renders every fold mode (and the unfolded baseline with and without culling)\n"
    "on the same K views, checks every folded image bit for bit against the\n"
    "unfolded one, and prints Table 1 (render time, memory) and Table 2\n"
    "(pre-build, per-frame update) with ratios to the unfolded baseline.\n"
    "\n"
    "  --size WxH             image size (default 1280x720)\n"
    "  --views K              cameras on a path around the base view (default 8)\n"
    "  --frames N             measured frames per view and method (default 5)\n"
    "  --warmup N             frames before measuring (default 1)\n"
    "  --eye X,Y,Z --look-at X,Y,Z   base view (default: the file's camera)\n"
    "  --random-views K       instead of the path, K views nobody chose (tools/random_views.h)\n"
    "  --seed S               the random views' seed (default 1)\n"
    "  --view-kind auto|interior|object   how they are drawn (default auto: by a probe)\n"
    "  --animate              move a fixed subset of instances every frame\n"
    "  --braid N              re-braiding budget per instance (default 2, 0 = off)\n"
    "  --backend opencl|cpu   (default opencl)   --device NAME   --threads N\n"
    "  --kernel tile|single|measure|auto   OpenCL kernel (default auto: tile on CPU devices)\n"
    "  --json F.json  --md F.md   also write the report\n"
    "  --align                instead: views rendered alone against the same views traced\n"
    "                         together, on a stereo pair and on paths of 2, 4, 8 and 16\n"
    "                         views, unfolded and folded xy, both kernels (docs/results.md)\n"
    "  --counts N,N,...       --align: the camera paths' lengths (default 2,4,8,16)\n"
    "  --baseline B           --align: the stereo pair's baseline (default 0.0032 of the\n"
    "                         scene's diagonal: 64 mm in a 20 m scene)\n"
    "exit code 3 when a folded (or aligned) image differs from the unfolded (or lone) one\n";

const char* kInfoUsage =
    "usage: rayfold info SCENE\n\nprints meshes, instances, triangles, bounds, the file's scenes and cameras, and\n"
    "every instance id with its mesh and node name\n";

struct RenderArgs {
  std::string scene = default_scene();
  int width = 1280, height = 720;
  std::optional<glm::dvec3> eye, look_at, up;
  std::optional<double> vfov, ortho;
  bool size_given = false;
  std::string cameras;           // --cameras FILE.json: one render per view
  std::optional<double> stereo;  // --stereo B: a left and a right view
  int align = 0;                 // --align N: views per pass; 0 = all (as many as a pass holds), -1 = auto
  bool fold_auto = false;        // --fold auto
  bool fold_given = false;       // --fold named at all
  double shift_x = 0.0, shift_y = 0.0;
  RendererOptions renderer;
  FrameOptions frame;
  int frames = 1;
  double fps = 30.0;  // --animate on an animated file: frame f at --time + f / fps
  std::string exr, png, stats, ids;
  bool quiet = false;
  std::vector<std::string> load_warnings;  // the loader's, for --stats (filled once loaded)
  bool verbose = false;
  bool compare = false;
  LoadOptions load;
};

std::string with_commas(size_t n) {
  std::string s = std::to_string(n);
  for (int i = static_cast<int>(s.size()) - 3; i > 0; i -= 3) s.insert(static_cast<size_t>(i), ",");
  return s;
}

Scene load_scene(const std::string& path, const LoadOptions& options = {}) {
  std::vector<std::string> warnings;
  Scene scene = load_gltf(path, &warnings, options);
  for (const std::string& w : warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  return scene;
}

BraidOptions parse_braid(const std::string& option, const std::string& text) {
  BraidOptions b;
  b.items_per_instance = static_cast<size_t>(cli::parse_int(option, text, 0, 1024));
  b.enabled = b.items_per_instance > 0;
  b.min_items = b.enabled ? b.min_items : 0;
  return b;
}

// Options render and bench share: which tracer, which device, how built.
// Returns false when `a` is none of them.
bool parse_renderer_option(const std::string& a, cli::Args& args, RendererOptions& r) {
  if (a == "--backend") {
    const std::string b = args.value(a);
    if (b == "opencl")
      r.backend = Backend::opencl;
    else if (b == "cpu")
      r.backend = Backend::cpu;
    else
      throw UsageError("--backend: '" + b + "' is not opencl or cpu");
  } else if (a == "--kernel") {
    const std::string k = args.value(a);
    if (k == "tile")
      r.kernel = KernelChoice::tile;
    else if (k == "single")
      r.kernel = KernelChoice::single;
    else if (k == "auto")
      r.kernel = KernelChoice::automatic;
    else if (k == "measure")
      r.kernel = KernelChoice::measure;
    else
      throw UsageError("--kernel: '" + k + "' is not tile, single, measure or auto");
  } else if (a == "--device") {
    r.device_hint = args.value(a);
  } else if (a == "--fast") {
    r.precision = KernelPrecision::fast;
  } else if (a == "--threads") {
    r.threads = static_cast<unsigned>(cli::parse_int(a, args.value(a), 0, 1024));
  } else if (a == "--braid") {
    r.braid = parse_braid(a, args.value(a));
  } else {
    return false;
  }
  return true;
}

// After parsing: options that contradict each other.
void check_renderer_options(const RendererOptions& r) {
  if (r.backend == Backend::cpu && r.kernel != KernelChoice::automatic)
    throw UsageError("--kernel: the CPU backend runs the reference tracer, not an OpenCL kernel");
  if (r.backend == Backend::cpu && !r.device_hint.empty())
    throw UsageError("--device: the CPU backend runs the reference tracer on no OpenCL device");
}

struct Output {
  const char* option;
  const std::string* path;
  const char* extension;
};

// The extension decides the format: a mismatch is an error, not a file of
// one kind under another's name. Kinds have different extensions, so no two
// outputs can name one file either.
void check_outputs(std::initializer_list<Output> outputs) {
  namespace fs = std::filesystem;
  for (const Output& o : outputs) {
    if (o.path->empty()) continue;
    std::string ext = fs::path(*o.path).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (ext != o.extension)
      throw UsageError(std::string(o.option) + ": '" + *o.path + "' must end in " + o.extension +
                       " (-o writes OpenEXR, --png a PNG preview, --stats JSON)");
  }
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
      r.size_given = true;
    } else if (a == "--cameras") {
      r.cameras = args.value(a);
    } else if (a == "--align") {
      const std::string v = args.value(a);
      r.align = v == "auto" ? -1 : v == "all" ? 0 : cli::parse_int(a, v, 1, RF_GROUP_LIMIT);
    } else if (a == "--stereo") {
      r.stereo = cli::parse_double(a, args.value(a));
      if (!(*r.stereo > 0.0)) throw UsageError("--stereo: the baseline must be positive (world units)");
    } else if (a == "--eye") {
      r.eye = cli::parse_vec3(a, args.value(a));
    } else if (a == "--look-at") {
      r.look_at = cli::parse_vec3(a, args.value(a));
    } else if (a == "--up") {
      r.up = cli::parse_vec3(a, args.value(a));
    } else if (a == "--ortho") {
      r.ortho = cli::parse_double(a, args.value(a));
    } else if (a == "--vfov") {
      r.vfov = cli::parse_double(a, args.value(a));
    } else if (a == "--scene") {
      r.load.scene = cli::parse_int(a, args.value(a), 0, 1 << 30);
    } else if (a == "--camera") {
      r.load.camera = cli::parse_int(a, args.value(a), 0, 1 << 30);
    } else if (a == "--time") {
      r.load.time = cli::parse_double(a, args.value(a));
    } else if (parse_renderer_option(a, args, r.renderer)) {
    } else if (a == "--fold") {
      const std::string v = args.value(a);
      r.fold_auto = v == "auto";
      r.fold_given = true;
      if (!r.fold_auto) r.frame.fold = cli::parse_fold(a, v);
    } else if (a == "--shift") {
      const std::string v = args.value(a);
      const size_t comma = v.find(',');
      if (comma == std::string::npos) throw UsageError("--shift: '" + v + "' is not SX,SY");
      r.shift_x = cli::parse_double(a, v.substr(0, comma));
      r.shift_y = cli::parse_double(a, v.substr(comma + 1));
    } else if (a == "--animate") {
      r.frame.animate_frame = 0;
    } else if (a == "--compare") {
      r.compare = true;
    } else if (a == "--no-cull") {
      r.frame.cull = false;
    } else if (a == "--fps") {
      r.fps = cli::parse_double(a, args.value(a));
      if (!(r.fps > 0.0 && r.fps <= 1e6)) throw UsageError("--fps: must be in (0, 1e6] frames per second");
    } else if (a == "--frames") {
      r.frames = cli::parse_int(a, args.value(a), 1, 100000);
    } else if (a == "-o" || a == "--output") {
      r.exr = args.value(a);
    } else if (a == "--png") {
      r.png = args.value(a);
    } else if (a == "--stats") {
      r.stats = args.value(a);
    } else if (a == "--ids") {
      r.ids = args.value(a);
    } else if (a == "-q" || a == "--quiet") {
      r.quiet = true;
    } else if (a == "-v" || a == "--verbose") {
      r.verbose = true;
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
  if (r.vfov && r.ortho) throw UsageError("--vfov and --ortho: a view is perspective or orthographic, not both");
  if (!r.cameras.empty() || r.stereo) {
    const char* what = !r.cameras.empty() ? "--cameras" : "--stereo";
    if (!r.cameras.empty() && r.stereo) throw UsageError("--cameras and --stereo: one list of views at a time");
    if (r.compare || r.frame.animate_frame >= 0 || r.frames != 1 || r.shift_x != 0.0 || r.shift_y != 0.0)
      throw UsageError(std::string(what) +
                       ": renders each view once; --compare, --animate, --frames and --shift "
                       "do not combine with it");
    if (!r.cameras.empty() && (r.size_given || r.eye || r.vfov || r.ortho || r.up))
      throw UsageError(
          "--cameras: the file gives the size and every camera; --size, --eye, --look-at, --up, "
          "--vfov and --ortho do not combine with it");
    if (r.ortho) throw UsageError("--stereo: a stereo pair is two perspective views");
  } else if (r.align != 0) {
    throw UsageError("--align: aligns the views of --cameras or --stereo");
  }
  if (r.fold_auto && r.compare) throw UsageError("--compare: compares a fold with none; name the fold");
  check_outputs(
      {{"-o", &r.exr, ".exr"}, {"--png", &r.png, ".png"}, {"--stats", &r.stats, ".json"}, {"--ids", &r.ids, ".json"}});
  if (r.compare && r.fold_given && r.frame.fold == FoldMode::none)
    throw UsageError(
        "--compare --fold none: --compare checks a fold against none; name y, x or xy (or leave --fold "
        "out for xy)");
  if (r.compare && r.frame.fold == FoldMode::none) r.frame.fold = FoldMode::xy;
  check_renderer_options(r.renderer);
  return r;
}

// The EXR's record of the view and the instances (image_output.h).
ExrMetadata exr_metadata(const Camera& camera, const Scene& scene, const RenderArgs& args) {
  ExrMetadata m;
  const Intrinsics k = intrinsics(camera);
  m.view = ExrMetadata::View{camera.world_from_camera, k.fx, k.fy, k.cx, k.cy, is_orthographic(camera)};
  for (const Instance& i : scene.instances) m.instance_names.push_back(i.name);
  m.strings = {{"version", RAYFOLD_VERSION},
               {"scene", args.scene},
               {"fold", fold_name(args.frame.fold)},
               {"depth", "Z is the distance from the eye along the pixel's ray (not camera-space z); +inf on a miss"},
               {"miss", "InstanceID and PrimitiveID are 4294967295 on a miss"}};
  return m;
}

// The view as --stats and --ids record it: pose (OpenGL axes, row-major),
// intrinsics, eye.
nlohmann::json camera_json(const Camera& camera) {
  const Intrinsics k = intrinsics(camera);
  nlohmann::json m = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m.push_back(camera.world_from_camera[c][r]);
  const glm::dvec3 eye(camera.world_from_camera[3]);
  return {{"width", camera.width},
          {"height", camera.height},
          {"eye", {eye.x, eye.y, eye.z}},
          {"camera_to_world", m},
          {"convention", "opengl: +x right, +y up, looking down -z; row-major"},
          {"projection", is_orthographic(camera) ? "orthographic" : "perspective"},
          {"intrinsics", {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}}},
          {"intrinsics_units", is_orthographic(camera) ? "pixels per world unit; cx, cy pixels" : "pixels"},
          {"pixel_centres", "at (x + 0.5, y + 0.5) from the top-left corner, y down"},
          {"vfov_degrees", camera.vfov_degrees}};
}

// --ids: what each InstanceID of the outputs is in the file.
void write_ids(const std::string& path, const RenderArgs& args, const Scene& scene) {
  nlohmann::json instances = nlohmann::json::array();
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    const Instance& inst = scene.instances[i];
    // The node index too: many real files repeat names.
    instances.push_back({{"id", i},
                         {"name", inst.name},
                         {"node", inst.node},
                         {"mesh", inst.mesh},
                         {"mesh_name", scene.meshes[inst.mesh].name}});
  }
  const nlohmann::json j = {{"scene", args.scene},
                            {"miss", RF_INVALID},
                            {"note", "InstanceID indexes instances; PrimitiveID is the triangle within the mesh"},
                            {"instances", instances}};
  write_text_file(path, j.dump(2) + "\n");
}

// The pass of a camera list that traced a view, with the views beside it.
struct PassInfo {
  size_t index = 0;
  size_t views = 1;
};

// --stats: one view's figures. A view of a camera list (`pass` given) was
// traced with the others of its pass, so its times are the pass's.
void write_stats(const std::string& path, const RenderArgs& args, const Scene& scene, const Camera& camera,
                 const Renderer& renderer, const RenderResult& result, double load_ms,
                 std::optional<PassInfo> pass = std::nullopt) {
  nlohmann::json j;
  j["rayfold_version"] = RAYFOLD_VERSION;
  j["scene"] = args.scene;
  j["width"] = camera.width;
  j["height"] = camera.height;
  if (pass)
    j["pass"] = {{"index", pass->index},
                 {"views", pass->views},
                 {"note", "times_ms are the whole pass's: its views were traced together"}};
  j["backend"] = args.renderer.backend == Backend::opencl ? "opencl" : "cpu";
  j["device"] = renderer.device_name();
  j["kernel"] = result.kernel;
  j["kernel_reason"] = result.kernel_reason;
  j["frames"] = result.frames.size();
  j["instances"] = scene.instances.size();
  j["meshes"] = scene.meshes.size();
  j["triangles"] = scene.triangle_count();
  j["rays"] = result.rays;
  j["fold"] = fold_name(result.fold);
  j["fold_requested"] = fold_name(args.frame.fold);
  j["camera"] = camera_json(camera);
  j["options"] = {{"cull", args.frame.cull},
                  {"animate", args.frame.animate_frame >= 0},
                  {"braid", args.renderer.braid.enabled ? args.renderer.braid.items_per_instance : 0},
                  {"threads", args.renderer.threads},
                  {"precision", args.renderer.precision == KernelPrecision::exact ? "exact" : "fast"}};
  size_t hit = 0;
  for (const rf_pixel_hit& h : result.hits) hit += h.instance != RF_INVALID;
  j["pixels"] = {{"hit", hit}, {"miss", result.hits.size() - hit}};
  j["instances_after_culling"] = result.frame_stats.kept;
  j["instances_out_of_range"] = result.views.empty() ? 0 : result.views[0].out_of_range;
  j["warnings"] = args.load_warnings;  // the loader's, then the trace's
  for (const std::string& w : result.warnings) j["warnings"].push_back(w);
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
  write_text_file(path, j.dump(2) + "\n");
}

// The folded and unfolded renders of one view side by side.
void print_comparison(const RenderResult& none, const RenderResult& folded, FoldMode fold) {
  auto total = [](const FrameTimes& t) { return t.ray_list_ms + t.trace_ms + t.readback_ms; };
  const double pixels = static_cast<double>(none.hits.size());
  const size_t differ = count_differing_pixels(none.hits, folded.hits);
  const std::string folded_name = std::string("folded ") + fold_name(fold);
  std::printf("\n  %-28s %14s %14s\n", "", "unfolded", folded_name.c_str());
  std::printf("  %-28s %14s %14s\n", "rays traced", with_commas(none.rays).c_str(), with_commas(folded.rays).c_str());
  std::printf("  %-28s %14zu %14zu\n", "instances in the TLAS", none.instances, folded.instances);
  std::printf("  %-28s %14.2f %14.2f\n", "update ms (cull+TLAS+upload)",
              none.median.cull_ms + none.median.tlas_ms + none.median.upload_ms,
              folded.median.cull_ms + folded.median.tlas_ms + folded.median.upload_ms);
  std::printf("  %-28s %14.2f %14.2f\n", "trace ms", none.median.trace_ms, folded.median.trace_ms);
  std::printf("  %-28s %14.2f %14.2f\n", "T ms (rays+trace+readback)", total(none.median), total(folded.median));
  std::printf("  %-28s %14.2f %14.2f\n", "Mpixels/s (T)", pixels / (total(none.median) * 1e3),
              pixels / (total(folded.median) * 1e3));
  std::printf("  %-28s %14s %13.2fx\n", "speed-up (T)", "", total(none.median) / total(folded.median));
  if (differ == 0)
    std::printf("  %-28s %29s\n", "hit info", "identical (8 channels, every pixel)");
  else
    std::printf("  %-28s %22zu pixels DIFFER\n", "hit info", differ);
}

// An output name with one frame field (%d, %04d, ...): the name of frame f.
// Returns the name unchanged when it has no field; a second field or any
// other % is a usage error.
std::string frame_name(const std::string& option, const std::string& name, int frame, bool* has_field) {
  std::string out;
  bool field = false;
  for (size_t i = 0; i < name.size(); ++i) {
    if (name[i] != '%') {
      out += name[i];
      continue;
    }
    size_t j = i + 1;
    while (j < name.size() && std::isdigit(static_cast<unsigned char>(name[j]))) ++j;
    if (j >= name.size() || name[j] != 'd' || field || j - i > 3)
      throw UsageError(option + ": '" + name + "' may hold one frame field such as %04d, and no other %");
    char buf[32];
    std::snprintf(buf, sizeof buf, ("%" + name.substr(i + 1, j - i - 1) + "d").c_str(), frame);
    out += buf;
    field = true;
    i = j;
  }
  if (has_field) *has_field = field;
  return out;
}

// The output name of one view: the view's index in a frame field for a
// camera list (required when it has several views), "-left"/"-right" before
// the extension for a stereo pair.
std::string view_output(const std::string& option, const std::string& name, const cli::View& v, bool stereo,
                        size_t views) {
  if (name.empty()) return name;
  if (stereo) {
    if (name.find('%') != std::string::npos)
      throw UsageError(option + ": '" + name + "': a stereo pair is named NAME-left and NAME-right, without a field");
    const size_t dot = name.rfind('.');
    return name.substr(0, dot) + "-" + v.label + name.substr(dot);
  }
  bool field = false;
  const std::string out = frame_name(option, name, std::stoi(v.label), &field);
  if (!field && views > 1)
    throw UsageError(option + ": '" + name + "' needs a view field such as %04d for " + std::to_string(views) +
                     " views");
  return out;
}

// --fold auto and --align auto: the choice the cost model predicts fastest
// for these views (alignable ones: the first view's intrinsics), applied to
// r and the renderer and printed. The kernel is chosen too unless named.
void choose_automatically(RenderArgs& r, Renderer& renderer, const std::vector<Camera>& views, bool quiet) {
  if (!r.fold_auto && r.align >= 0) return;
  std::vector<Camera> group;
  for (const Camera& c : views)
    if (can_align(renderer.scene_data(), views[0], c)) group.push_back(c);
  std::vector<FoldMode> folds{r.frame.fold};
  if (r.fold_auto) folds = {FoldMode::none, FoldMode::y, FoldMode::x, FoldMode::xy};
  std::vector<KernelKind> kernels{renderer.kernel()};
  const bool kernel_free = r.renderer.backend == Backend::opencl && r.renderer.kernel == KernelChoice::automatic;
  if (kernel_free) kernels = {KernelKind::tile, KernelKind::single};
  std::vector<int> aligns{r.align > 0 ? r.align : RF_GROUP_LIMIT};
  if (r.align < 0 && group.size() > 1) aligns = {1, RF_GROUP_LIMIT};
  if (group.size() == 1) aligns = {1};
  const AutoChoice c = choose_fastest(renderer, group, folds, kernels, aligns);
  r.frame.fold = c.best.fold;
  if (r.align < 0) r.align = c.best.align;
  if (kernel_free) {
    renderer.set_kernel(c.best.kernel, "predicted fastest (docs/cost_model.md)");
    r.renderer.kernel = c.best.kernel == KernelKind::tile ? KernelChoice::tile : KernelChoice::single;
  }
  if (quiet) return;
  std::printf("auto: %s, predicted %.2f ms per view (trace %.2f + update %.2f); probing %zu choices took %.0f ms:\n",
              choice_name(c.best).c_str(), c.predictions[0].total_ms(), c.predictions[0].trace_ms,
              c.predictions[0].update_ms, c.predictions.size(), c.probe_ms);
  for (const Prediction& p : c.predictions)
    std::printf("  %-24s %8.2f ms/view\n", choice_name(p.choice).c_str(), p.total_ms());
}

// A slow program build is a machine's first use (PoCL compiles, then
// caches); said once so that the wait and the first frame's time (which
// also holds the compile for the work-group size) are not taken for rayfold's.
void announce_program_build(const Renderer& renderer, Progress& progress, bool quiet) {
  const double ms = renderer.program_build_ms();
  if (quiet || ms < 500.0) return;
  char text[400];
  std::snprintf(text, sizeof text,
                "note: the OpenCL kernels took %.1f s to compile: the first use of this device and rayfold version; "
                "PoCL caches them ($XDG_CACHE_HOME/pocl or ~/.cache/pocl), so later runs skip this. The first frame "
                "also compiles for its work-group size: --frames N reports medians.\n",
                ms / 1000.0);
  progress.print(stderr, text);
}

// --cameras and --stereo: the views traced in passes of aligned views, each
// view's outputs written.
int render_views(RenderArgs r, const Scene& scene, const std::vector<cli::View>& views, Progress& progress,
                 double load_ms) {
  const bool stereo = r.stereo.has_value();
  for (const cli::View& v : views)
    for (auto [option, out] : {std::pair{"-o", &r.exr}, {"--png", &r.png}, {"--stats", &r.stats}})
      if (!out->empty()) check_writable(view_output(option, *out, v, stereo, views.size()));
  progress.stage("building the bottom-level trees and the kernels");
  Renderer renderer(scene, r.renderer);
  announce_program_build(renderer, progress, r.quiet);
  std::vector<Camera> cameras;
  for (const cli::View& v : views) cameras.push_back(v.camera);
  const bool align_auto = r.align < 0;
  progress.clear();
  choose_automatically(r, renderer, cameras, r.quiet);
  const int align = r.align > 0 ? r.align : RF_GROUP_LIMIT;
  const std::vector<std::vector<size_t>> passes = plan_passes(renderer.scene_data(), cameras, align, r.frame.fold);
  if (!r.quiet)
    std::printf("rayfold render  %s  %zu views in %zu passes (--align %s)  fold %s\n", r.scene.c_str(), views.size(),
                passes.size(),
                align_auto    ? ("auto: " + std::to_string(align)).c_str()
                : r.align > 0 ? std::to_string(r.align).c_str()
                              : "all",
                fold_name(r.frame.fold));
  progress.stage("tracing", views.size());
  const auto start = Clock::now();
  RenderResult result;
  size_t done = 0;
  double trace_ms = 0.0;
  char line[512];
  for (size_t p = 0; p < passes.size(); ++p) {
    const std::vector<size_t>& pass = passes[p];
    std::vector<Camera> pass_cameras;
    for (size_t i : pass) pass_cameras.push_back(cameras[i]);
    renderer.render_views_into(result, pass_cameras, 1, r.frame);
    trace_ms += result.median.trace_ms;
    // One line per pass: its views were traced together, so the time is theirs together.
    if (!r.quiet) {
      std::snprintf(line, sizeof line, "  pass %zu of %zu: %zu view%s, trace %.2f ms\n", p + 1, passes.size(),
                    pass.size(), pass.size() == 1 ? "" : "s", result.median.trace_ms);
      progress.print(stdout, line);
    }
    for (size_t k = 0; k < pass.size(); ++k) {
      const cli::View& v = views[pass[k]];
      const RenderResult vr = view_result(result, k);
      const ExrMetadata metadata = exr_metadata(v.camera, scene, r);
      const int w = v.camera.width, h = v.camera.height;
      if (!r.exr.empty()) write_exr(view_output("-o", r.exr, v, stereo, views.size()), vr.hits, w, h, &metadata);
      if (!r.png.empty()) write_png(view_output("--png", r.png, v, stereo, views.size()), vr.hits, w, h);
      if (!r.stats.empty())
        write_stats(view_output("--stats", r.stats, v, stereo, views.size()), r, scene, v.camera, renderer, vr, load_ms,
                    PassInfo{p, pass.size()});
      for (const std::string& w : vr.warnings)
        progress.print(stderr, "warning: view " + v.label + ": " + w + " (docs/exactness.md)\n");
      progress.update(++done);
      if (!r.quiet) {
        const glm::dvec3 eye(v.camera.world_from_camera[3]);
        std::snprintf(line, sizeof line, "    view %-6s %dx%d  eye (%g, %g, %g)\n", v.label.c_str(), w, h, eye.x, eye.y,
                      eye.z);
        progress.print(stdout, line);
      }
    }
  }
  progress.clear();
  if (!r.quiet) {
    const double wall_s = ms_since(start) / 1000.0;
    std::printf("  %zu views in %zu passes: trace %.2f ms in all (%.3f ms a view), %.1f views/s with the writes\n",
                views.size(), passes.size(), trace_ms, trace_ms / views.size(), views.size() / wall_s);
  }
  if (!r.ids.empty()) write_ids(r.ids, r, scene);
  if (!r.quiet && r.exr.empty() && r.png.empty() && r.stats.empty() && r.ids.empty())
    std::printf("  nothing written (-o F_%%04d.exr, --png, --stats or --ids write the results)\n");
  return 0;
}

int run_render(cli::Args& args) {
  RenderArgs r = parse_render(args);
  // Frame sequences: with a frame field in -o or --png, every frame is
  // written (animated frames advance with --animate).
  bool sequence = false;
  for (auto [option, out] : {std::pair{"-o", &r.exr}, {"--png", &r.png}}) {
    bool field = false;
    if (!out->empty()) frame_name(option, *out, 0, &field);
    sequence = sequence || field;
  }
  if (sequence && r.compare) throw UsageError("--compare: compares one frame; write a sequence without it");
  // Fail on unwritable outputs before any expensive work.
  for (const std::string* out : {&r.exr, &r.png, &r.stats, &r.ids})
    if (!out->empty()) check_writable(frame_name("output", *out, 0, nullptr));

  // Progress on a terminal only; the table and warnings come after it.
  Progress progress(!r.quiet);
  progress.stage("loading " + r.scene);
  auto t0 = Clock::now();
  GltfFile file(r.scene, r.load);
  Scene scene = file.scene_at(r.load.time);
  // Warnings are printed under -q too: it silences the table and progress.
  for (const std::string& w : file.warnings()) std::fprintf(stderr, "warning: %s\n", w.c_str());
  r.load_warnings = file.warnings();
  const double load_ms = ms_since(t0);
  // --animate plays the file's own animations when it has any (frame f at
  // --time + f / --fps); other files get the synthetic motion (animation.h).
  const bool play = r.frame.animate_frame >= 0 && file.animated();
  // A substitute is announced, -q or not.
  if (r.frame.animate_frame >= 0 && !play)
    std::fprintf(stderr,
                 "warning: --animate: %s has no animations; every fourth instance moves instead (a synthetic "
                 "motion for benchmarking updates)\n",
                 r.scene.c_str());
  FrameOptions frame_options = r.frame;
  if (play) frame_options.animate_frame = -1;
  const double start_time = std::isnan(r.load.time) ? 0.0 : r.load.time;

  // Auto-framing of an animated file frames the pose at its start (time 0)
  // whenever a time is asked for, so that --time T and frame k of
  // --animate at the same time see the same camera.
  const bool timed = !std::isnan(r.load.time) || r.frame.animate_frame >= 0;
  CameraSpec spec = scene.camera               ? *scene.camera
                    : timed && file.animated() ? frame_bounds(file.scene_at(0.0).world_bounds())
                                               : frame_bounds(scene.world_bounds());
  const bool auto_framed = !scene.camera && !r.eye;
  if (r.eye) {
    // A camera given on the command line is given whole: +Y up unless --up.
    spec.eye = *r.eye;
    spec.look_at = *r.look_at;
    spec.up = glm::dvec3(0.0, 1.0, 0.0);
  }
  if (r.up) spec.up = *r.up;
  if (r.vfov) {
    spec.vfov_degrees = *r.vfov;
    spec.orthographic = false;
  }
  if (r.ortho) {
    spec.orthographic = true;
    spec.ymag = *r.ortho;
  }
  if (!r.cameras.empty() || r.stereo) {
    std::vector<cli::View> views =
        !r.cameras.empty() ? cli::read_camera_list(r.cameras) : cli::stereo_pair(spec, *r.stereo, r.width, r.height);
    return render_views(r, scene, views, progress, load_ms);
  }
  const Camera camera = make_camera(spec, r.width, r.height, r.shift_x, r.shift_y);

  progress.stage("building the bottom-level trees and the kernels");
  t0 = Clock::now();
  auto renderer_ptr = std::make_unique<Renderer>(scene, r.renderer);
  std::vector<char> moved_since_build(scene.instances.size(), 0);  // since the renderer's trees were built
  const double setup_ms = ms_since(t0);
  announce_program_build(*renderer_ptr, progress, r.quiet);
  if (r.fold_auto) {
    progress.clear();
    choose_automatically(r, *renderer_ptr, {camera}, r.quiet);
    frame_options.fold = r.frame.fold;
  }
  // The file's pose for frame f: instances that moved since the trees were
  // built go to FrameOptions::moved; changed meshes (morph weights, skins)
  // rebuild the trees.
  size_t rebuilds = 0;
  auto pose_frame = [&](int f, FrameOptions& o) {
    std::vector<uint32_t> changed;
    if (apply_pose(scene, file.scene_at(start_time + f / r.fps), &changed)) {
      renderer_ptr = std::make_unique<Renderer>(scene, r.renderer);
      moved_since_build.assign(scene.instances.size(), 0);
      ++rebuilds;
    }
    for (uint32_t i : changed) moved_since_build[i] = 1;
    o.moved.clear();
    for (size_t i = 0; i < moved_since_build.size(); ++i)
      if (moved_since_build[i]) o.moved.push_back(static_cast<uint32_t>(i));
  };
  progress.stage("tracing", sequence || play ? static_cast<size_t>(r.frames) : 0);
  std::optional<RenderResult> unfolded;
  if (r.compare && !play) {
    FrameOptions none = frame_options;
    none.fold = FoldMode::none;
    unfolded = renderer_ptr->render(camera, r.frames, none);
  }
  RenderResult result;
  std::vector<std::string> written;
  double write_ms = 0.0;  // the EXR and PNG writes (ZIP compression is most of it)
  const ExrMetadata metadata = exr_metadata(camera, scene, r);
  if (!sequence && !play) {
    Renderer& renderer = *renderer_ptr;
    result = renderer.render(camera, r.frames, frame_options);
    progress.stage("writing");
    const auto w0 = Clock::now();
    if (!r.exr.empty()) write_exr(r.exr, result.hits, r.width, r.height, &metadata);
    if (!r.png.empty()) write_png(r.png, result.hits, r.width, r.height);
    write_ms += ms_since(w0);
    for (const std::string* out : {&r.exr, &r.png})
      if (!out->empty()) written.push_back(*out);
  } else {
    std::vector<FrameTimes> times;
    FrameOptions o = frame_options;
    for (int f = 0; f < r.frames; ++f) {
      if (play)
        pose_frame(f, o);
      else if (frame_options.animate_frame >= 0)
        o.animate_frame = frame_options.animate_frame + f;
      renderer_ptr->render_into(result, camera, 1, o);
      times.push_back(result.frames.front());
      const bool last = f + 1 == r.frames;
      if (sequence || last) {
        const auto w0 = Clock::now();
        if (!r.exr.empty())
          write_exr(frame_name("output", r.exr, f, nullptr), result.hits, r.width, r.height, &metadata);
        if (!r.png.empty()) write_png(frame_name("output", r.png, f, nullptr), result.hits, r.width, r.height);
        write_ms += ms_since(w0);
      }
      progress.update(static_cast<size_t>(f + 1));
    }
    if (r.compare) {
      // The last frame's pose, unfolded.
      FrameOptions none = o;
      none.fold = FoldMode::none;
      unfolded = renderer_ptr->render(camera, 1, none);
    }
    for (const std::string* out : {&r.exr, &r.png})
      if (!out->empty())
        written.push_back(sequence ? frame_name("output", *out, 0, nullptr) + " .. " +
                                         frame_name("output", *out, r.frames - 1, nullptr) + " (" +
                                         std::to_string(r.frames) + " frames)"
                                   : *out);
    result.frames = times;
    result.median = median_times(times);
  }
  Renderer& renderer = *renderer_ptr;
  if (play && !r.quiet)
    std::fprintf(
        stderr, "playing the file's animation: %d frames from %g s at %g fps (it ends at %g s)%s\n", r.frames,
        start_time, r.fps, file.animation_end(),
        rebuilds ? (", trees rebuilt for " + std::to_string(rebuilds) + " frames whose meshes changed").c_str() : "");
  progress.clear();
  for (const std::string& w : result.warnings) std::fprintf(stderr, "warning: %s (docs/exactness.md)\n", w.c_str());

  if (!r.stats.empty()) write_stats(r.stats, r, scene, camera, renderer, result, load_ms);
  if (!r.ids.empty()) write_ids(r.ids, r, scene);

  if (!r.quiet) {
    const FrameTimes& m = result.median;
    const double mrays = result.rays / (m.trace_ms * 1e3);
    std::printf("rayfold render  %s  %dx%d  fold %s\n", r.scene.c_str(), r.width, r.height, fold_name(r.frame.fold));
    std::printf("  %-12s %s\n", "device", renderer.device_name().c_str());
    std::printf("  %-12s %s (%s)\n", "kernel", result.kernel.c_str(), result.kernel_reason.c_str());
    std::printf("  %-12s %s instances, %s meshes, %s triangles (%s stored)\n", "scene",
                with_commas(scene.instances.size()).c_str(), with_commas(scene.meshes.size()).c_str(),
                with_commas(scene.triangle_count()).c_str(), with_commas(scene.unique_triangle_count()).c_str());
    std::printf("  %-12s %9.2f ms   (SAH cost %.1f, depth %d)\n", "BLAS build", renderer.blas_build_ms(),
                renderer.scene_data().blas.sah_cost, renderer.scene_data().blas.max_depth);
    std::printf("  %-12s %9.2f ms   (%zu instances traced, from %zu in the scene; SAH cost %.1f)\n", "TLAS build",
                m.cull_ms + m.tlas_ms, result.frame_stats.kept, result.frame_stats.candidates,
                result.frame_stats.tlas_sah);
    std::printf("  %-12s %9.2f ms   (median of %zu frames)\n", "trace", m.trace_ms, result.frames.size());
    std::printf("  %-12s %9.2f   (%zu rays for %zu pixels: %.2f Mpixels/s)\n", "Mrays/s", mrays, result.rays,
                result.hits.size(), result.hits.size() / (m.trace_ms * 1e3));
    if (auto_framed)
      std::printf("  %-12s --eye %.17g,%.17g,%.17g --look-at %.17g,%.17g,%.17g --up 0,1,0 %s %.17g\n", "auto-framed",
                  spec.eye.x, spec.eye.y, spec.eye.z, spec.look_at.x, spec.look_at.y, spec.look_at.z,
                  spec.orthographic ? "--ortho" : "--vfov", spec.orthographic ? spec.ymag : spec.vfov_degrees);
    if (unfolded) print_comparison(*unfolded, result, r.frame.fold);
    if (r.verbose) {
      std::printf("  %-12s load %.2f ms, trees and kernels %.2f ms (BLAS %.2f ms, kernels %.2f ms), writing %.2f ms\n",
                  "stages", load_ms, setup_ms, renderer.blas_build_ms(), renderer.program_build_ms(), write_ms);
      for (size_t f = 0; f < result.frames.size(); ++f) {
        const FrameTimes& t = result.frames[f];
        std::printf("  %-12s cull %.3f, TLAS %.3f, upload %.3f, ray list %.3f, trace %.3f, readback %.3f ms\n",
                    ("frame " + std::to_string(f)).c_str(), t.cull_ms, t.tlas_ms, t.upload_ms, t.ray_list_ms,
                    t.trace_ms, t.readback_ms);
      }
    }
    for (const std::string& w : written) std::printf("  wrote %s\n", w.c_str());
    if (!r.stats.empty()) std::printf("  wrote %s\n", r.stats.c_str());
    if (!r.ids.empty()) std::printf("  wrote %s\n", r.ids.c_str());
    if (r.exr.empty() && r.png.empty() && r.stats.empty() && r.ids.empty())
      std::printf("  nothing written (-o F.exr, --png F.png or --stats F.json write the results)\n");
  }
  if (unfolded && count_differing_pixels(unfolded->hits, result.hits) != 0) {
    std::fprintf(stderr, "error: the folded render differs from the unfolded one\n");
    return 3;
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
  const Scene scene = load_scene(path);
  const Aabb b = scene.world_bounds();
  std::printf("%s\n", path.c_str());
  std::printf("  meshes      %s\n", with_commas(scene.meshes.size()).c_str());
  std::printf("  instances   %s\n", with_commas(scene.instances.size()).c_str());
  std::printf("  triangles   %s rendered, %s stored\n", with_commas(scene.triangle_count()).c_str(),
              with_commas(scene.unique_triangle_count()).c_str());
  if (b.empty())
    std::printf("  bounds      (empty)\n");
  else
    std::printf("  bounds      (%g, %g, %g) .. (%g, %g, %g)\n", b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z);
  for (size_t i = 0; i < scene.scene_names.size(); ++i)
    std::printf("  scene %-5zu %s%s\n", i, scene.scene_names[i].empty() ? "(unnamed)" : scene.scene_names[i].c_str(),
                static_cast<int>(i) == scene.scene_index ? "  [shown; --scene N picks another]" : "");
  for (size_t i = 0; i < scene.cameras.size(); ++i) {
    const Scene::FileCamera& c = scene.cameras[i];
    if (c.perspective)
      std::printf("  camera %-4zu node %d '%s': eye (%g, %g, %g), looking at (%g, %g, %g), vfov %g\n", i, c.node,
                  c.name.c_str(), c.spec.eye.x, c.spec.eye.y, c.spec.eye.z, c.spec.look_at.x, c.spec.look_at.y,
                  c.spec.look_at.z, c.spec.vfov_degrees);
    else
      std::printf("  camera %-4zu node %d '%s': eye (%g, %g, %g), looking at (%g, %g, %g), orthographic, ymag %g\n", i,
                  c.node, c.name.c_str(), c.spec.eye.x, c.spec.eye.y, c.spec.eye.z, c.spec.look_at.x, c.spec.look_at.y,
                  c.spec.look_at.z, c.spec.ymag);
  }
  // The ids the G-buffer's InstanceID channel holds (render --ids writes them as JSON).
  std::printf("  instance ids (InstanceID, mesh, node name):\n");
  for (size_t i = 0; i < scene.instances.size(); ++i)
    std::printf("    %-6zu mesh %-5u %s\n", i, scene.instances[i].mesh, scene.instances[i].name.c_str());
  return 0;
}

// Prints a bench report, writes it where asked; exit code 3 when it is not
// exact (its figures are then not valid).
int finish_report(const std::string& text, const std::string& json_text, bool exact, const std::string& json,
                  const std::string& md, const char* what) {
  std::fputs(text.c_str(), stdout);
  if (!json.empty()) write_text_file(json, json_text);
  if (!md.empty()) write_text_file(md, text);
  if (exact) return 0;
  std::fprintf(stderr, "error: %s; the figures are not valid\n", what);
  return 3;
}

int run_bench_command(cli::Args& args) {
  BenchOptions opt;
  opt.scene = default_scene();
  std::string json, md;
  bool have_scene = false, align = false;
  double baseline = 0.0;
  std::vector<int> counts{2, 4, 8, 16};
  while (!args.done()) {
    const std::string a = args.next();
    if (a == "--help" || a == "-h") {
      std::fputs(kBenchUsage, stdout);
      return 0;
    } else if (parse_view_path_option(a, args, opt, &have_scene)) {
    } else if (a == "--animate") {
      opt.animate = true;
    } else if (a == "--align") {
      align = true;
    } else if (a == "--counts") {
      counts.clear();
      for (const std::string& item : cli::split_list(a, args.value(a)))
        counts.push_back(cli::parse_int(a, item, 1, 64));
    } else if (a == "--baseline") {
      baseline = cli::parse_double(a, args.value(a));
      if (!(baseline > 0.0)) throw UsageError("--baseline: must be positive (world units)");
    } else if (parse_renderer_option(a, args, opt.renderer)) {
    } else if (a == "--json") {
      json = args.value(a);
    } else if (a == "--md") {
      md = args.value(a);
    } else {
      throw UsageError("bench: unknown option '" + a + "' (see rayfold bench --help)");
    }
  }
  check_view_path(opt);
  check_renderer_options(opt.renderer);
  check_outputs({{"--json", &json, ".json"}, {"--md", &md, ".md"}});
  for (const std::string* out : {&json, &md})
    if (!out->empty()) check_writable(*out);
  if (align && opt.animate) throw UsageError("--align measures still views; --animate does not combine with it");
  Progress progress(true);
  bool started = false;
  if (align) {
    AlignBenchOptions ao;
    static_cast<ViewPath&>(ao) = opt;
    ao.renderer = opt.renderer;
    ao.baseline = baseline;
    ao.counts = counts;
    const AlignReport report = run_align_bench(ao, [&](size_t done, size_t total) {
      if (!started) progress.stage("bench --align: views x ways x kernels", total);
      started = true;
      progress.update(done);
    });
    progress.clear();
    return finish_report(align_markdown(report), align_json(report), report.exact(), json, md,
                         "an aligned view differs from the same view alone");
  }
  const BenchReport report = run_bench(opt, [&](size_t done, size_t total) {
    if (!started) progress.stage("bench: views x methods x frames", total);
    started = true;
    progress.update(done);
  });
  progress.clear();
  return finish_report(bench_markdown(report), bench_json(report), report.exact(), json, md,
                       "folded output differs from the unfolded output");
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
  if (command == "--version" || command == "version") {
    std::printf("rayfold %s\n", RAYFOLD_VERSION);
    return 0;
  }
  if (command == "devices") {
    if (!args.done() && (args.peek() == "--help" || args.peek() == "-h")) {
      std::fputs(kDevicesUsage, stdout);
      return 0;
    }
    if (!args.done()) throw UsageError("devices: takes no arguments");
    std::printf("OpenCL devices (--device NAME picks the first whose platform or name contains NAME):\n%s",
                describe_devices(list_devices()).c_str());
    return 0;
  }
  if (command == "render") return run_render(args);
  if (command == "info") return run_info(args);
  if (command == "bench") return run_bench_command(args);
  throw UsageError("unknown command '" + command + "' (see rayfold --help)");
}

}  // namespace
}  // namespace rayfold::core

int main(int argc, char** argv) {
  // Line by line also into pipes and logs, as on a terminal.
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  return rayfold::core::cli::guarded_main([&] { return rayfold::core::run(argc, argv); });
}
