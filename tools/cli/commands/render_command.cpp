// `rayfold render`: one view, a frame sequence, a camera list or a stereo
// pair, traced and written.
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <optional>

#include "cli/camera_list.h"
#include "cli/commands/common.h"
#include "cli/commands/render_args.h"
#include "cli/commands/render_outputs.h"
#include "output/channels.h"
#include "fold/view_passes.h"
#include "opencl/cl_device.h"
#include "pipeline/auto_frame.h"
#include "cli/progress.h"
#include "reference/hit_compare.h"
#include "scene/animation.h"
#include "util/atomic_file.h"
#include "util/errors.h"
#include "output/image_output.h"
#include "util/timer.h"

namespace rayfold::core::commands {
namespace {

const char* kRenderUsage =
    "usage: rayfold render [SCENE] [options]\n"
    "\n"
    "  --size WxH             image size (default 1280x720)\n"
    "  --eye X,Y,Z            camera position         } without these, the file's\n"
    "  --look-at X,Y,Z        point looked at         } camera, else a chosen view:\n"
    "  --up X,Y,Z             up direction (0,1,0)    } an object whole, a room from inside\n"
    "                         (--up alone turns the file's camera)\n"
    "  --vfov DEG             vertical field of view (default: the file's, else 60); a\n"
    "                         perspective view also where the file's camera is orthographic\n"
    "  --ortho YMAG           an orthographic view, YMAG world units above and below the axis\n"
    "  --scene N              the file's scene N (default: its `scene`, else 0)\n"
    "  --camera N             the scene's camera N (default: its first camera,\n"
    "                         perspective or orthographic); `rayfold info` lists both\n"
    "  --time T               the pose of the file's animations at T seconds\n"
    "  --backend opencl|cpu   OpenCL device (default) or the CPU reference tracer\n"
    "  --device NAME          OpenCL device whose name contains NAME (cpu, gpu: by type)\n"
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
    "                         per traced instance (partial re-braiding;\n"
    "                         default 2, 0 = whole instances)\n"
    "  --no-merge             a tree per mesh, also for static instances that share\n"
    "                         a transform (by default they share one tree)\n"
    "  --no-cull              keep instances outside the view in the top-level tree\n"
    "  --threads N            CPU threads for loading, builds and the CPU backend (0 = all)\n"
    "  --frames N             trace N times and report the medians (default 1)\n"
    "  -o, --output F.exr     OpenEXR hit info: Z N.X N.Y N.Z U V InstanceID PrimitiveID;\n"
    "                         a frame field (out/frame_%04d.exr) writes every frame\n"
    "  --depth distance|planar  Z as the distance along the pixel's ray (default) or the\n"
    "                         depth along the camera's axis (Nuke's and Blender's Z)\n"
    "  --exact-depth          Z from each pixel's exact ray in double-float: within 2^-24\n"
    "                         of the exact value (the float ray's is off by up to 1e-4\n"
    "                         on grazing pixels); about 1.2x to 1.5x the frame time\n"
    "  --channels C,...       the EXR channels written: Z, N (N.X, N.Y, N.Z), UV (U, V),\n"
    "                         InstanceID, PrimitiveID (default: all eight)\n"
    "  --exr-compression M    zip (default), zips, piz, rle or none: OpenEXR's lossless\n"
    "                         methods; none writes 3 to 4 times faster, 10x the bytes\n"
    "  --png F.png            normal-shaded preview, misses black\n"
    "  --stats F.json         the camera, options, hit and miss counts, phase times, device buffers\n"
    "  --ids F.json           the id manifest: InstanceID -> the file's node name and mesh\n"
    "  --cameras F.json       render every view of a camera list, one output per view\n"
    "                         (-o out/view_%04d.exr by index, or out/%s.exr by the view's\n"
    "                         name: a transforms.json's file_path, a COLMAP image's name,\n"
    "                         less folders and extension); see docs/cli.md for the format; a\n"
    "                         NeRF / instant-ngp transforms.json (--size for one without w, h)\n"
    "  --colmap DIR           render every image of a COLMAP text model (DIR/cameras.txt,\n"
    "                         DIR/images.txt; PINHOLE and SIMPLE_PINHOLE cameras)\n"
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
    } else if (a == "--colmap") {
      r.colmap = args.value(a);
    } else if (a == "--depth") {
      const std::string v = args.value(a);
      if (v != "distance" && v != "planar")
        throw UsageError("--depth: 'distance' (along the ray, the default) or 'planar' (along the camera's axis), "
                         "not '" + v + "'");
      r.frame.planar_depth = v == "planar";
    } else if (a == "--exact-depth") {
      r.frame.exact_depth = true;
    } else if (a == "--exr-compression") {
      try {
        r.exr_compression = parse_exr_compression(args.value(a));
      } catch (const InputError& e) {
        throw UsageError(std::string("--exr-compression: ") + e.what());
      }
    } else if (a == "--channels") {
      try {
        r.channels = parse_channels(args.value(a));
      } catch (const InputError& e) {
        throw UsageError(e.what());
      }
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
  if (!r.cameras.empty() || !r.colmap.empty() || r.stereo) {
    const char* what = !r.cameras.empty() ? "--cameras" : !r.colmap.empty() ? "--colmap" : "--stereo";
    if ((!r.cameras.empty()) + (!r.colmap.empty()) + bool(r.stereo) > 1)
      throw UsageError("--cameras, --colmap and --stereo: one list of views at a time");
    if (r.compare || r.frame.animate_frame >= 0 || r.frames != 1 || r.shift_x != 0.0 || r.shift_y != 0.0)
      throw UsageError(std::string(what) +
                       ": renders each view once; --compare, --animate, --frames and --shift "
                       "do not combine with it");
    if ((!r.cameras.empty() || !r.colmap.empty()) && (r.eye || r.vfov || r.ortho || r.up))
      throw UsageError(std::string(what) +
                       ": the file gives every camera; --eye, --look-at, --up, --vfov and --ortho do not combine "
                       "with it");
    if (!r.colmap.empty() && r.size_given)
      throw UsageError("--colmap: cameras.txt gives the image sizes; --size does not combine with it");
    if (r.ortho) throw UsageError("--stereo: a stereo pair is two perspective views");
  } else if (r.align != 0) {
    throw UsageError("--align: aligns the views of --cameras or --stereo");
  }
  if (r.fold_auto && r.compare) throw UsageError("--compare: compares a fold with none; name the fold");
  if (r.frame.exact_depth && (r.channels & rayfold::kDepth) == 0)
    throw UsageError("--exact-depth: it is Z's; --channels leaves Z out");
  if (r.frame.exact_depth && r.renderer.precision == KernelPrecision::fast)
    throw UsageError("--exact-depth runs on the exact kernels; --fast reorders the double-float steps away");
  check_outputs(
      {{"-o", &r.exr, ".exr"}, {"--png", &r.png, ".png"}, {"--stats", &r.stats, ".json"}, {"--ids", &r.ids, ".json"}});
  // No output reads the normal: the kernels skip it.
  r.frame.normals = (r.channels & rayfold::kNormal) != 0 || !r.png.empty();
  if (r.compare && r.fold_given && r.frame.fold == Fold::none)
    throw UsageError(
        "--compare --fold none: --compare checks a fold against none; name y, x or xy (or leave --fold "
        "out for xy)");
  if (r.compare && r.frame.fold == Fold::none) r.frame.fold = Fold::xy;
  check_renderer_options(r.renderer);
  return r;
}

// --fold auto and --align auto: the choice the cost model predicts fastest
// for these views (alignable ones: the first view's intrinsics), applied to
// r and the renderer and printed. The kernel is chosen too unless named.
void choose_automatically(RenderArgs& r, Pipeline& renderer, const std::vector<Camera>& views, bool quiet) {
  if (!r.fold_auto && r.align >= 0) return;
  std::vector<Camera> group;
  for (const Camera& c : views)
    if (can_align(renderer.scene_data(), views[0], c)) group.push_back(c);
  std::vector<Fold> folds{r.frame.fold};
  if (r.fold_auto) folds = {Fold::none, Fold::y, Fold::x, Fold::xy};
  std::vector<KernelKind> kernels{renderer.kernel()};
  const bool kernel_free = r.renderer.backend == Backend::opencl && r.renderer.kernel == Kernel::automatic;
  if (kernel_free) kernels = {KernelKind::tile, KernelKind::single};
  std::vector<int> aligns{r.align > 0 ? r.align : RF_GROUP_LIMIT};
  if (r.align < 0 && group.size() > 1) aligns = {1, RF_GROUP_LIMIT};
  if (group.size() == 1) aligns = {1};
  const AutoChoice c = choose_fastest(renderer, group, folds, kernels, aligns);
  r.frame.fold = c.best.fold;
  if (r.align < 0) r.align = c.best.align;
  if (kernel_free) {
    renderer.set_kernel(c.best.kernel, "predicted fastest (docs/cost_model.md)");
    r.renderer.kernel = c.best.kernel == KernelKind::tile ? Kernel::tile : Kernel::single;
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
void announce_program_build(const Pipeline& renderer, Progress& progress, bool quiet) {
  const double ms = renderer.program_build_ms();
  if (quiet || ms < 500.0) return;
  char text[400];
  std::snprintf(text, sizeof text,
                "note: the OpenCL kernels took %.1f s to compile: the first use of this device and rayfold version; "
                "they are cached (rayfold's in ~/.cache/rayfold/kernels or $RAYFOLD_KERNEL_CACHE, PoCL's in "
                "~/.cache/pocl), so later runs skip this. The first frame also compiles for its work-group size: "
                "--frames N reports medians.\n",
                ms / 1000.0);
  progress.print(stderr, text);
}

// --cameras and --stereo: the views traced in passes of aligned views, each
// view's outputs written.
// Every view's outputs made ready (prepare_output); two views that would
// write one file (their names end alike under %s) are a UsageError naming both.
void check_view_outputs(const RenderArgs& r, const std::vector<cli::View>& views) {
  for (auto [option, out] : {std::pair{"-o", &r.exr}, {"--png", &r.png}, {"--stats", &r.stats}}) {
    if (out->empty()) continue;
    std::map<std::string, const cli::View*> written;
    for (const cli::View& v : views) {
      const std::string path = view_output(option, *out, v, r.stereo.has_value(), views.size());
      const auto [at, fresh] = written.emplace(path, &v);
      if (!fresh)
        throw UsageError(std::string(option) + ": views " + at->second->label + " ('" + at->second->name +
                         "') and " + v.label + " ('" + v.name + "') would both write " + path +
                         "; name the views by index (%04d)");
      prepare_output(path);
    }
  }
}

int render_views(RenderArgs r, const Scene& scene, Pipeline& renderer, const std::vector<cli::View>& views,
                 Progress& progress, double load_ms) {
  const bool stereo = r.stereo.has_value();
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
      if (!r.exr.empty())
        write_exr(view_output("-o", r.exr, v, stereo, views.size()), vr.hits, w, h, &metadata, r.channels,
                  r.exr_compression);
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

}  // namespace

int run_render(cli::Args& args) {
  RenderArgs r = parse_render(args);
  // Frame sequences: with a frame field in -o or --png, every frame is
  // written (animated frames advance with --animate).
  // A list of views names its outputs per view (check_view_outputs).
  const bool view_list = !r.cameras.empty() || !r.colmap.empty() || r.stereo;
  bool sequence = false;
  for (auto [option, out] : {std::pair{"-o", &r.exr}, {"--png", &r.png}}) {
    bool field = false;
    if (!out->empty() && !view_list) frame_name(option, *out, 0, &field);
    sequence = sequence || field;
  }
  if (sequence && r.compare) throw UsageError("--compare: compares one frame; write a sequence without it");
  // Fail on unwritable outputs before any expensive work: a camera file's
  // once it is read, a stereo pair's now.
  for (const std::string* out : {&r.exr, &r.png, &r.stats, &r.ids})
    if (!out->empty() && (!view_list || out == &r.ids)) prepare_output(frame_name("output", *out, 0, nullptr));
  if (r.stereo) check_view_outputs(r, {cli::View{Camera{}, "left", ""}, cli::View{Camera{}, "right", ""}});

  // The OpenCL drivers load while the scene is read: the whole process 0.91x
  // to 0.97x the time on the shared scenes (docs/results.md).
  std::optional<OpenClPreload> preload;
  if (r.renderer.backend == Backend::opencl) preload.emplace();
  // Progress on a terminal only; the table and warnings come after it.
  Progress progress(!r.quiet);
  progress.stage("loading " + r.scene);
  auto t0 = Clock::now();
  r.load.threads = r.renderer.threads;
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
  if (r.frame.animate_frame >= 0 && !play) r.renderer.merge.dynamic = animated_instances(scene.instances.size());
  const double start_time = std::isnan(r.load.time) ? 0.0 : r.load.time;

  // A list of views from a file: its outputs are checked before any
  // expensive work, as the single view's are above.
  const bool listed = !r.cameras.empty() || !r.colmap.empty();
  std::vector<cli::View> views;
  if (listed) {
    std::string note;
    views = !r.cameras.empty() ? cli::read_cameras_file(r.cameras, r.size_given ? r.width : 0,
                                                        r.size_given ? r.height : 0, &note)
                               : cli::read_colmap_dir(r.colmap);
    if (!note.empty() && !r.quiet) progress.print(stderr, "note: " + note + "\n");
    check_view_outputs(r, views);
  }

  progress.stage("building the bottom-level trees and the kernels");
  t0 = Clock::now();
  auto renderer_ptr = std::make_unique<Pipeline>(scene, r.renderer);
  std::vector<char> moved_since_build(scene.instances.size(), 0);  // since the renderer's trees were built
  const double setup_ms = ms_since(t0);
  announce_program_build(*renderer_ptr, progress, r.quiet);
  if (listed) return render_views(r, scene, *renderer_ptr, views, progress, load_ms);

  // Without a camera in the file or on the command line, the view is chosen
  // from the scene's trees (pipeline/auto_frame.h): an interior from inside.
  // An animated file is framed at its start (time 0) whenever a time is
  // asked for, so that --time T and frame k of --animate at the same time
  // see the same camera.
  const bool timed = !std::isnan(r.load.time) || r.frame.animate_frame >= 0;
  const bool auto_framed = !scene.camera && !r.eye;
  CameraSpec spec;
  ViewKind framed_kind = ViewKind::object;
  if (scene.camera) {
    spec = *scene.camera;
  } else if (auto_framed) {
    progress.stage("choosing a view");
    PipelineOptions cpu_options;
    cpu_options.backend = Backend::cpu;
    cpu_options.threads = r.renderer.threads;
    AutoFrame framed;
    if (timed && file.animated()) {
      const Scene start = file.scene_at(0.0);
      Pipeline cpu(start, cpu_options);
      framed = auto_frame(start, cpu);
    } else {
      Pipeline cpu(scene, cpu_options, renderer_ptr->shared_scene_data());
      framed = auto_frame(scene, cpu);
    }
    spec = framed.spec;
    framed_kind = framed.kind;
  }
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
  if (r.stereo) {
    views = cli::stereo_pair(spec, *r.stereo, r.width, r.height);
    check_view_outputs(r, views);
    return render_views(r, scene, *renderer_ptr, views, progress, load_ms);
  }
  const Camera camera = make_camera(spec, r.width, r.height, r.shift_x, r.shift_y);

  if (r.fold_auto) {
    progress.clear();
    choose_automatically(r, *renderer_ptr, {camera}, r.quiet);
    frame_options.fold = r.frame.fold;
  }
  // The file's pose for frame f: instances that moved since the trees were
  // built go to FrameOptions::moved; changed meshes (morph weights, skins)
  // rebuild the trees.
  size_t rebuilds = 0;
  // An instance merged into a static tree (bvh/blas.h) that moves is built
  // dynamic from then on.
  auto pose_frame = [&](int f, FrameOptions& o) {
    std::vector<uint32_t> changed;
    bool rebuild = apply_pose(scene, file.scene_at(start_time + f / r.fps), &changed);
    std::vector<uint8_t>& dynamic = r.renderer.merge.dynamic;
    dynamic.resize(scene.instances.size(), 0);
    for (uint32_t i : changed) {
      rebuild |= renderer_ptr->scene_data().blas.merged[i] != 0;
      dynamic[i] = 1;
    }
    if (rebuild) {
      renderer_ptr = std::make_unique<Pipeline>(scene, r.renderer);
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
    none.fold = Fold::none;
    unfolded = renderer_ptr->render(camera, r.frames, none);
  }
  RenderResult result;
  std::vector<std::string> written;
  double write_ms = 0.0;  // the EXR and PNG writes (ZIP compression is most of it)
  const ExrMetadata metadata = exr_metadata(camera, scene, r);
  if (!sequence && !play) {
    Pipeline& renderer = *renderer_ptr;
    result = renderer.render(camera, r.frames, frame_options);
    progress.stage("writing");
    const auto w0 = Clock::now();
    if (!r.exr.empty()) write_exr(r.exr, result.hits, r.width, r.height, &metadata, r.channels, r.exr_compression);
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
        // A frame field may name the folder too (out/%04d/z.exr).
        for (const std::string* out : {&r.exr, &r.png})
          if (!out->empty() && f > 0) make_output_folders(frame_name("output", *out, f, nullptr));
        if (!r.exr.empty())
          write_exr(frame_name("output", r.exr, f, nullptr), result.hits, r.width, r.height, &metadata, r.channels,
                    r.exr_compression);
        if (!r.png.empty()) write_png(frame_name("output", r.png, f, nullptr), result.hits, r.width, r.height);
        write_ms += ms_since(w0);
      }
      progress.update(static_cast<size_t>(f + 1));
    }
    if (r.compare) {
      // The last frame's pose, unfolded.
      FrameOptions none = o;
      none.fold = Fold::none;
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
  Pipeline& renderer = *renderer_ptr;
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
    if (auto_framed) {
      std::printf("  %-12s %s\n", "view", framed_kind == ViewKind::interior
                                              ? "chosen: an interior, seen from inside along its length"
                                              : "chosen: the whole scene from outside");
      std::printf("  %-12s --eye %.17g,%.17g,%.17g --look-at %.17g,%.17g,%.17g --up %.17g,%.17g,%.17g %s %.17g\n",
                  "auto-framed", spec.eye.x, spec.eye.y, spec.eye.z, spec.look_at.x, spec.look_at.y, spec.look_at.z,
                  spec.up.x, spec.up.y, spec.up.z, spec.orthographic ? "--ortho" : "--vfov",
                  spec.orthographic ? spec.ymag : spec.vfov_degrees);
    }
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

}  // namespace rayfold::core::commands
