// `rayfold render`: one view, a frame sequence, a camera list or a stereo
// pair, traced and written through the public API (rayfold/rayfold.h), as
// a C++ or Python caller would.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <optional>

#include "cli/camera_list.h"
#include "cli/commands/common.h"
#include "cli/commands/render_args.h"
#include "cli/commands/render_outputs.h"
#include "cli/progress.h"
#include "fixtures/synthetic_motion.h"
#include "util/atomic_file.h"
#include "util/errors.h"
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
    "  --channels C,...       the planes written (default: the visibility buffer, Z, N,\n"
    "                         UV, InstanceID, PrimitiveID); also the G-buffer's Ns\n"
    "                         (shading_normal), TexCoord, TexCoord1, P (position),\n"
    "                         Pref (object_position), MaterialID, BaseColor,\n"
    "                         MetallicRoughness, Emission, Label, Tangent,\n"
    "                         MappedNormal: docs/channels.md; with a list of views\n"
    "                         (--cameras, --colmap, --stereo) or --animate's frames,\n"
    "                         Flow and FlowVisible: each one's optical flow to the next\n"
    "  --label-key KEY        the member of a node's extras that labels it for Label\n"
    "                         (default: the whole extras value); labels in the EXR header\n"
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

rayfold::Vec3 vec3(const glm::dvec3& v) { return {v.x, v.y, v.z}; }

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
      r.options.depth = v == "planar" ? rayfold::Depth::planar : rayfold::Depth::distance;
    } else if (a == "--exact-depth") {
      r.options.exact_depth = true;
    } else if (a == "--exr-compression") {
      try {
        r.exr_compression = rayfold::exr_compression(args.value(a));
      } catch (const InputError& e) {
        throw UsageError(std::string("--exr-compression: ") + e.what());
      }
    } else if (a == "--channels") {
      try {
        r.channels = rayfold::parse_channels(args.value(a));
      } catch (const InputError& e) {
        throw UsageError(e.what());
      }
    } else if (a == "--align") {
      const std::string v = args.value(a);
      r.align = v == "auto" ? -1 : v == "all" ? 0 : cli::parse_int(a, v, 1, rayfold::kMaxAlignedViews);
    } else if (a == "--stereo") {
      r.stereo = cli::parse_double(a, args.value(a));
      if (!(*r.stereo > 0.0)) throw UsageError("--stereo: the baseline must be positive (world units)");
    } else if (a == "--eye") {
      r.eye = vec3(cli::parse_vec3(a, args.value(a)));
    } else if (a == "--look-at") {
      r.look_at = vec3(cli::parse_vec3(a, args.value(a)));
    } else if (a == "--up") {
      r.up = vec3(cli::parse_vec3(a, args.value(a)));
    } else if (a == "--ortho") {
      r.ortho = cli::parse_double(a, args.value(a));
    } else if (a == "--vfov") {
      r.vfov = cli::parse_double(a, args.value(a));
    } else if (a == "--scene") {
      r.load.scene = cli::parse_int(a, args.value(a), 0, 1 << 30);
    } else if (a == "--camera") {
      r.load.camera = cli::parse_int(a, args.value(a), 0, 1 << 30);
    } else if (a == "--label-key") {
      r.load.label_key = args.value(a);
    } else if (a == "--time") {
      r.load.time = cli::parse_double(a, args.value(a));
    } else if (parse_renderer_option(a, args, r.options)) {
    } else if (a == "--fold") {
      const std::string v = args.value(a);
      r.fold_auto = v == "auto";
      r.fold_given = true;
      if (!r.fold_auto) try {
          r.fold = cli::parse_fold(a, v);
        } catch (const UsageError&) {
          throw UsageError(a + ": '" + v + "' is not none, y, x, xy or auto");
        }
    } else if (a == "--shift") {
      const std::string v = args.value(a);
      const size_t comma = v.find(',');
      if (comma == std::string::npos) throw UsageError("--shift: '" + v + "' is not SX,SY");
      r.shift_x = cli::parse_double(a, v.substr(0, comma));
      r.shift_y = cli::parse_double(a, v.substr(comma + 1));
    } else if (a == "--animate") {
      r.animate = true;
    } else if (a == "--compare") {
      r.compare = true;
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
    if (r.compare || r.animate || r.frames != 1 || r.shift_x != 0.0 || r.shift_y != 0.0)
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
  if ((r.channels & rayfold::kFlowChannels) && r.cameras.empty() && r.colmap.empty() && !r.stereo && !r.animate)
    throw UsageError(
        "--channels: flow and flow_visible go from each view to the next: of a list (--cameras, --colmap, "
        "--stereo: the left view's flow is its disparity to the right) or of --animate's frames; a single "
        "view has none to go to");
  if ((r.channels & rayfold::kFlowChannels) && r.animate && r.frames < 2)
    throw UsageError("--channels: flow goes from each of --animate's frames to the next; one frame (--frames " +
                     std::to_string(r.frames) + ") has none to go to");
  if ((r.channels & rayfold::kFlowChannels) && r.compare)
    throw UsageError("--channels: flow and --compare: --compare checks the visibility, render flow without it");
  if (r.options.exact_depth && (r.channels & rayfold::kDepth) == 0)
    throw UsageError("--exact-depth: it is Z's; --channels leaves Z out");
  if (r.options.exact_depth && r.options.fast_math)
    throw UsageError("--exact-depth runs on the exact kernels; --fast reorders the double-float steps away");
  check_outputs(
      {{"-o", &r.exr, ".exr"}, {"--png", &r.png, ".png"}, {"--stats", &r.stats, ".json"}, {"--ids", &r.ids, ".json"}});
  if (r.compare && r.fold_given && r.fold == Fold::none)
    throw UsageError(
        "--compare --fold none: --compare checks a fold against none; name y, x or xy (or leave --fold "
        "out for xy)");
  if (r.compare && r.fold == Fold::none) r.fold = Fold::xy;
  check_renderer_options(r.options);
  return r;
}

// --fold auto and --align auto: the choice the cost model predicts fastest
// for these views (Renderer::choose_fastest; its kernel too unless one was
// named), applied to r and printed.
void choose_automatically(RenderArgs& r, rayfold::Renderer& renderer, const std::vector<rayfold::Camera>& views) {
  if (!r.fold_auto && r.align >= 0) return;
  std::vector<Fold> folds;
  if (!r.fold_auto) folds = {r.fold};
  std::vector<int> aligns;
  if (r.align > 0) aligns = {r.align};
  if (r.align == 0) aligns = {rayfold::kMaxAlignedViews};
  const rayfold::AutoChoice c = renderer.choose_fastest(views, folds, aligns);
  r.fold = c.fold;
  if (r.align < 0) r.align = c.align;
  if (r.quiet) return;
  const rayfold::Prediction& best = c.predictions.at(0);
  std::printf("auto: %s, predicted %.2f ms per view (trace %.2f + update %.2f); probing %zu choices took %.0f ms:\n",
              best.name.c_str(), best.total_ms(), best.trace_ms, best.update_ms, c.predictions.size(), c.probe_ms);
  for (const rayfold::Prediction& p : c.predictions)
    std::printf("  %-24s %8.2f ms/view\n", p.name.c_str(), p.total_ms());
}

// A slow program build is a machine's first use (PoCL compiles, then
// caches); said once so that the wait and the first frame's time (which
// also holds the compile for the work-group size) are not taken for rayfold's.
void announce_program_build(const rayfold::Renderer& renderer, Progress& progress, bool quiet) {
  const double ms = renderer.build_stats().kernels_ms;
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

// A render's warning as printed: what it may have lost points to
// docs/exactness.md unless it names its own page.
std::string render_warning(const std::string& w) {
  return "warning: " + w + (w.find("docs/") == std::string::npos ? " (docs/exactness.md)" : "") + "\n";
}
void print_render_warning(const std::string& w) { std::fputs(render_warning(w).c_str(), stderr); }

// Every view's outputs made ready (prepare_output); two views that would
// write one file (their names end alike under %s) are a UsageError naming
// both (rayfold::view_files). views: each view's label and name (cli::View's).
void check_view_outputs(const RenderArgs& r, const std::vector<std::pair<std::string, std::string>>& views) {
  for (auto [option, out] : {std::pair{"-o", &r.exr}, {"--png", &r.png}, {"--stats", &r.stats}}) {
    if (out->empty()) continue;
    if (!r.stereo && out->find("%s") != std::string::npos) {
      std::vector<std::optional<std::string>> names;
      for (const auto& v : views) names.emplace_back(v.second);
      for (const std::string& path : named_view_files(option, *out, names)) prepare_output(path);
      continue;
    }
    for (const auto& [label, name] : views)
      prepare_output(view_output(option, *out, label, name, r.stereo.has_value(), views.size()));
  }
}

void check_view_outputs(const RenderArgs& r, const std::vector<cli::View>& views) {
  std::vector<std::pair<std::string, std::string>> names;
  for (const cli::View& v : views) names.emplace_back(v.label, v.name);
  check_view_outputs(r, names);
}

// --cameras, --colmap and --stereo: the views traced in passes of aligned
// views (Renderer::render_views), each view's outputs written as it comes.
int render_views(RenderArgs r, const rayfold::Scene& scene, rayfold::Renderer& renderer,
                 const std::vector<cli::View>& views, Progress& progress, double load_ms) {
  const bool stereo = r.stereo.has_value();
  std::vector<rayfold::Camera> cameras;
  for (const cli::View& v : views) cameras.push_back(v.camera);
  const bool align_auto = r.align < 0;
  progress.clear();
  choose_automatically(r, renderer, cameras);
  const int align = r.align > 0 ? r.align : 0;
  const std::vector<std::vector<size_t>> passes = renderer.passes(cameras, r.fold, align);
  std::vector<PassInfo> pass_of(views.size());
  for (size_t p = 0; p < passes.size(); ++p)
    for (size_t i : passes[p]) pass_of[i] = {p, passes[p].size()};
  if (!r.quiet)
    std::printf("rayfold render  %s  %zu views in %zu passes (--align %s)  fold %s\n", r.scene.c_str(), views.size(),
                passes.size(),
                align_auto    ? ("auto: " + std::to_string(r.align)).c_str()
                : r.align > 0 ? std::to_string(r.align).c_str()
                              : "all",
                fold_name(r.fold));
  progress.stage("tracing", views.size());
  const auto start = Clock::now();
  size_t done = 0;
  double trace_ms = 0.0;
  char line[512];
  renderer.render_views(
      cameras,
      [&](size_t i, rayfold::GBuffer&& g) {
        const cli::View& v = views[i];
        const PassInfo& pass = pass_of[i];
        // One line per pass, at its first view: its views were traced
        // together, so the time is theirs together.
        if (i == passes[pass.index].front()) {
          const double pass_ms = g.stages.trace_ms;
          trace_ms += pass_ms;
          if (!r.quiet) {
            std::snprintf(line, sizeof line, "  pass %zu of %zu: %zu view%s, trace %.2f ms\n", pass.index + 1,
                          passes.size(), pass.views, pass.views == 1 ? "" : "s", pass_ms);
            progress.print(stdout, line);
          }
        }
        if (!r.exr.empty())
          rayfold::write_exr(view_output("-o", r.exr, v.label, v.name, stereo, views.size()), g, v.camera, scene,
                             r.exr_compression, r.channels);
        if (!r.png.empty()) rayfold::write_png(view_output("--png", r.png, v.label, v.name, stereo, views.size()), g);
        if (!r.stats.empty())
          write_stats(view_output("--stats", r.stats, v.label, v.name, stereo, views.size()), r, scene, v.camera,
                      renderer, g, g.stages, 1, load_ms, pass);
        for (const std::string& w : g.warnings) progress.print(stderr, render_warning("view " + v.label + ": " + w));
        progress.update(++done);
        if (!r.quiet) {
          const rayfold::Vec3 eye = v.camera.eye();
          std::snprintf(line, sizeof line, "    view %-6s %dx%d  eye (%g, %g, %g)\n", v.label.c_str(), v.camera.width(),
                        v.camera.height(), eye[0], eye[1], eye[2]);
          progress.print(stdout, line);
        }
      },
      r.fold, align, r.render_channels());
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

// The single view's outputs checked before any expensive work: a frame
// field where --animate writes several frames, writable paths, a stereo
// pair's two names. Returns whether -o or --png names a frame sequence.
bool check_outputs(const RenderArgs& r) {
  // Frame sequences: with a frame field in -o or --png, every frame is
  // written (animated frames advance with --animate).
  // A list of views names its outputs per view (check_view_outputs).
  const bool view_list = !r.cameras.empty() || !r.colmap.empty() || r.stereo;
  bool sequence = false;
  for (auto [option, out] : {std::pair{"-o", &r.exr}, {"--png", &r.png}}) {
    bool field = false;
    if (!out->empty() && !view_list) frame_name(option, *out, 0, &field);
    sequence = sequence || field;
    // Animated frames differ: each is written, none dropped unsaid.
    if (!out->empty() && !view_list && !field && r.animate && r.frames > 1)
      throw UsageError(std::string(option) + ": '" + *out + "': --animate renders " + std::to_string(r.frames) +
                       " frames; name them with a frame field such as %04d, or render --frames 1");
  }
  if (sequence && r.compare) throw UsageError("--compare: compares one frame; write a sequence without it");
  // Fail on unwritable outputs before any expensive work: a camera file's
  // once it is read, a stereo pair's now.
  for (const std::string* out : {&r.exr, &r.png, &r.stats, &r.ids})
    if (!out->empty() && (!view_list || out == &r.ids)) prepare_output(frame_name("output", *out, 0, nullptr));
  if (r.stereo) check_view_outputs(r, std::vector<std::pair<std::string, std::string>>{{"left", ""}, {"right", ""}});
  return sequence;
}

// The view of a single render: the command line's camera over the file's,
// else one chosen from the scene's trees (Scene::default_view: an interior
// from inside). *source: where the view came from.
rayfold::View choose_view(const RenderArgs& r, rayfold::Scene& scene, Progress& progress, double start_time,
                          rayfold::ViewSource* source) {
  // An animated file is framed at its start (time 0) whenever a time is
  // asked for, so that --time T and frame k of --animate at the same time
  // see the same camera.
  const bool timed = !std::isnan(r.load.time) || r.animate;
  *source = rayfold::ViewSource::file_camera;
  rayfold::View view;
  if (!r.eye || scene.has_camera()) {  // the file's camera lends its field of view to --eye
    if (!r.eye) progress.stage("choosing a view");
    const bool reframe = !scene.has_camera() && timed && scene.animated();
    if (reframe) scene.set_time(0.0);
    view = scene.default_view(source);
    if (reframe) scene.set_time(start_time);
  }
  if (r.eye) {
    // A camera given on the command line is given whole: +Y up unless --up.
    view.eye = *r.eye;
    view.target = *r.look_at;
    view.up = {0.0, 1.0, 0.0};
  }
  if (r.up) view.up = *r.up;
  if (r.vfov) {
    view.vfov_degrees = *r.vfov;
    view.orthographic = false;
  }
  if (r.ortho) {
    view.orthographic = true;
    view.half_height = *r.ortho;
  }
  return view;
}

// What a single view's run measured and wrote: the table's contents.
struct SingleViewRun {
  rayfold::GBuffer g;                      // the last frame's
  std::vector<rayfold::StageTimes> times;  // each frame's
  rayfold::StageTimes median;
  std::vector<std::string> written;  // the image outputs, a sequence as its first .. last
  double load_ms = 0.0, setup_ms = 0.0;
  double write_ms = 0.0;  // the EXR and PNG writes (ZIP compression is most of it)
  // --compare: the last frame's pose, unfolded, as many frames.
  std::optional<rayfold::GBuffer> unfolded;
  rayfold::StageTimes unfolded_times;
};

// The frames of a single view, each posed by pose_frame(f) and written
// where -o or --png names a sequence, the last one always.
void render_frames(const RenderArgs& r, const rayfold::Scene& scene, rayfold::Renderer& renderer,
                   const rayfold::Camera& camera, bool sequence, double start_time,
                   const std::function<void(int)>& pose_frame, Progress& progress, SingleViewRun& run) {
  const unsigned channels = r.render_channels();
  rayfold::GBuffer& g = run.g;
  std::vector<std::string> said;  // every frame's warnings, each once (a mesh's missing attribute: the first frame's)
  for (int f = 0; f < r.frames; ++f) {
    pose_frame(f);
    // Flow goes to the next frame's pose; the last frame has none to go to.
    if (!(channels & rayfold::kFlowChannels))
      renderer.render_into(g, camera, r.fold, channels);
    else if (f + 1 < r.frames)
      renderer.render_into(g, camera, r.fold, channels, rayfold::FlowTo{camera, start_time + (f + 1) / r.fps});
    else
      g = renderer.render_views({camera}, r.fold, 1, channels).front();
    run.times.push_back(g.stages);
    append_unsaid(said, g.warnings);
    const bool last = f + 1 == r.frames;
    if (sequence || last) {
      if (last) progress.stage("writing");
      const auto w0 = Clock::now();
      // A frame field may name the folder too (out/%04d/z.exr).
      for (const std::string* out : {&r.exr, &r.png})
        if (!out->empty() && f > 0) make_output_folders(frame_name("output", *out, f, nullptr));
      if (!r.exr.empty())
        rayfold::write_exr(frame_name("output", r.exr, f, nullptr), g, camera, scene, r.exr_compression, r.channels);
      if (!r.png.empty()) rayfold::write_png(frame_name("output", r.png, f, nullptr), g);
      run.write_ms += ms_since(w0);
    }
    progress.update(static_cast<size_t>(f + 1));
  }
  for (const std::string* out : {&r.exr, &r.png})
    if (!out->empty())
      run.written.push_back(sequence ? frame_name("output", *out, 0, nullptr) + " .. " +
                                           frame_name("output", *out, r.frames - 1, nullptr) + " (" +
                                           std::to_string(r.frames) + " frames)"
                                     : *out);
  run.median = median_stages(run.times);
  if (r.compare) {
    std::vector<rayfold::StageTimes> none_times;
    run.unfolded.emplace();
    for (int f = 0; f < r.frames; ++f) {
      renderer.render_into(*run.unfolded, camera, Fold::none, channels);
      none_times.push_back(run.unfolded->stages);
    }
    run.unfolded_times = median_stages(none_times);
  }
  g.warnings = said;  // the run's, for --stats too
}

// The table `rayfold render` prints for a single view (not under -q).
void print_table(const RenderArgs& r, const rayfold::Scene& scene, const rayfold::Renderer& renderer,
                 const SingleViewRun& run, const rayfold::View& view, rayfold::ViewSource source, bool auto_framed) {
  const rayfold::GBuffer& g = run.g;
  const rayfold::StageTimes& m = run.median;
  const rayfold::BuildStats built = renderer.build_stats();
  const size_t pixels = static_cast<size_t>(r.width) * r.height;
  std::printf("rayfold render  %s  %dx%d  fold %s\n", r.scene.c_str(), r.width, r.height, fold_name(r.fold));
  std::printf("  %-12s %s\n", "device", renderer.device_name().c_str());
  std::printf("  %-12s %s (%s)\n", "kernel", g.kernel.c_str(), g.kernel_reason.c_str());
  std::printf("  %-12s %s instances, %s meshes, %s triangles (%s stored)\n", "scene",
              with_commas(scene.instance_count()).c_str(), with_commas(scene.mesh_count()).c_str(),
              with_commas(scene.triangle_count()).c_str(), with_commas(scene.stored_triangle_count()).c_str());
  std::printf("  %-12s %9.2f ms   (SAH cost %.1f, depth %d)\n", "BLAS build", built.trees_ms, built.sah_cost,
              built.depth);
  std::printf("  %-12s %9.2f ms   (%zu instances traced, from %zu in the scene; SAH cost %.1f)\n", "TLAS build",
              m.cull_ms + m.tlas_ms, g.top_level.traced_instances, g.top_level.scene_instances, g.top_level.sah_cost);
  std::printf("  %-12s %9.2f ms   (median of %zu frames)\n", "trace", m.trace_ms, run.times.size());
  std::printf("  %-12s %9.2f   (%zu rays for %zu pixels: %.2f Mpixels/s)\n", "Mrays/s", g.rays / (m.trace_ms * 1e3),
              g.rays, pixels, pixels / (m.trace_ms * 1e3));
  if (auto_framed) {
    std::printf("  %-12s %s\n", "view",
                source == rayfold::ViewSource::interior ? "chosen: an interior, seen from inside along its length"
                                                        : "chosen: the whole scene from outside");
    std::printf("  %-12s --eye %.17g,%.17g,%.17g --look-at %.17g,%.17g,%.17g --up %.17g,%.17g,%.17g %s %.17g\n",
                "auto-framed", view.eye[0], view.eye[1], view.eye[2], view.target[0], view.target[1], view.target[2],
                view.up[0], view.up[1], view.up[2], view.orthographic ? "--ortho" : "--vfov",
                view.orthographic ? view.half_height : view.vfov_degrees);
  }
  if (run.unfolded) print_comparison(*run.unfolded, run.unfolded_times, g, m);
  if (r.verbose) {
    std::printf("  %-12s load %.2f ms, trees and kernels %.2f ms (BLAS %.2f ms, kernels %.2f ms), writing %.2f ms\n",
                "stages", run.load_ms, run.setup_ms, built.trees_ms, built.kernels_ms, run.write_ms);
    for (size_t f = 0; f < run.times.size(); ++f) {
      const rayfold::StageTimes& t = run.times[f];
      std::printf("  %-12s cull %.3f, TLAS %.3f, upload %.3f, ray list %.3f, trace %.3f, readback %.3f ms\n",
                  ("frame " + std::to_string(f)).c_str(), t.cull_ms, t.tlas_ms, t.upload_ms, t.ray_list_ms, t.trace_ms,
                  t.readback_ms);
    }
  }
  for (const std::string& w : run.written) std::printf("  wrote %s\n", w.c_str());
  if (!r.stats.empty()) std::printf("  wrote %s\n", r.stats.c_str());
  if (!r.ids.empty()) std::printf("  wrote %s\n", r.ids.c_str());
  if (r.exr.empty() && r.png.empty() && r.stats.empty() && r.ids.empty())
    std::printf("  nothing written (-o F.exr, --png F.png or --stats F.json write the results)\n");
}

}  // namespace

int run_render(cli::Args& args) {
  RenderArgs r = parse_render(args);
  const bool sequence = check_outputs(r);

  // The OpenCL drivers load while the scene is read: the whole process 0.91x
  // to 0.97x the time on the shared scenes (docs/results.md).
  std::optional<rayfold::OpenClPreload> preload;
  if (r.options.backend == Backend::opencl) preload.emplace();
  // Progress on a terminal only; the table and warnings come after it.
  Progress progress(!r.quiet);
  progress.stage("loading " + r.scene);
  SingleViewRun run;
  auto t0 = Clock::now();
  r.load.threads = r.options.threads;
  rayfold::Scene scene = rayfold::Scene::load(r.scene, r.load);
  // Warnings are printed under -q too: it silences the table and progress.
  for (const std::string& w : scene.warnings()) std::fprintf(stderr, "warning: %s\n", w.c_str());
  run.load_ms = ms_since(t0);
  // --animate plays the file's own animations when it has any (frame f at
  // --time + f / --fps); other files get the synthetic motion.
  const bool play = r.animate && scene.animated();
  // A substitute is announced, -q or not.
  if (r.animate && !play)
    std::fprintf(stderr,
                 "warning: --animate: %s has no animations; every fourth instance moves instead (a synthetic "
                 "motion for benchmarking updates)\n",
                 r.scene.c_str());
  std::optional<SyntheticMotion> motion;
  if (r.animate && !play && (r.channels & rayfold::kFlowChannels))
    throw InputError(r.scene,
                     "--channels flow with --animate needs the file's own animations, which it has none of "
                     "(the synthetic motion is for benchmarking updates)");
  if (r.animate && !play) {
    motion.emplace(scene);
    motion->pose(scene, 0);  // moved before the trees are built: they keep trees of their own
  }
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
  rayfold::Renderer renderer(scene, r.options);
  run.setup_ms = ms_since(t0);
  announce_program_build(renderer, progress, r.quiet);
  if (listed) return render_views(r, scene, renderer, views, progress, run.load_ms);

  rayfold::ViewSource source;
  const rayfold::View view = choose_view(r, scene, progress, start_time, &source);
  const bool auto_framed = !r.eye && source != rayfold::ViewSource::file_camera;
  if (r.stereo) {
    views = cli::stereo_pair(view, *r.stereo, r.width, r.height);
    check_view_outputs(r, views);
    return render_views(r, scene, renderer, views, progress, run.load_ms);
  }
  const rayfold::Camera camera = rayfold::Camera::from_view(view, r.width, r.height, r.shift_x, r.shift_y);

  if (r.fold_auto) {
    progress.clear();
    choose_automatically(r, renderer, {camera});
  }
  // Frame f's pose: the file's animations at its time, or the synthetic
  // motion's frame f; the renderer places what moved and rebuilds the trees
  // where meshes changed (morph weights, skins).
  auto pose_frame = [&](int f) {
    if (play) scene.set_time(start_time + f / r.fps);
    if (motion) motion->pose(scene, f);
  };
  progress.stage("tracing", sequence || play ? static_cast<size_t>(r.frames) : 0);
  render_frames(r, scene, renderer, camera, sequence, start_time, pose_frame, progress, run);
  const rayfold::BuildStats built = renderer.build_stats();
  if (play && !r.quiet)
    std::fprintf(stderr, "playing the file's animation: %d frame%s from %g s at %g fps (it ends at %g s)%s\n", r.frames,
                 r.frames == 1 ? "" : "s", start_time, r.fps, scene.animation_end(),
                 built.builds > 1 ? (", trees rebuilt " + std::to_string(built.builds - 1) +
                                     (built.builds == 2 ? " time" : " times") + " for frames whose meshes changed")
                                        .c_str()
                                  : "");
  progress.clear();
  for (const std::string& w : run.g.warnings) print_render_warning(w);

  if (!r.stats.empty())
    write_stats(r.stats, r, scene, camera, renderer, run.g, run.median, run.times.size(), run.load_ms);
  if (!r.ids.empty()) write_ids(r.ids, r, scene);
  if (!r.quiet) print_table(r, scene, renderer, run, view, source, auto_framed);
  if (run.unfolded && rayfold::count_differing_pixels(*run.unfolded, run.g) != 0) {
    std::fprintf(stderr, "error: the folded render differs from the unfolded one\n");
    return 3;
  }
  return 0;
}

}  // namespace rayfold::core::commands
