#include "bench/bench.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <sstream>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <nlohmann/json.hpp>

#include "reference/hit_compare.h"
#include "scene/animation.h"
#include "scene/gltf_loader.h"
#include "util/errors.h"
#include "util/parallel.h"

namespace rayfold::core {
namespace {

struct Method {
  const char* name;
  Fold fold;
  bool cull;
};
const Method kMethods[] = {
    {"none (no culling)", Fold::none, false},
    {"none", Fold::none, true},
    {"y", Fold::y, true},
    {"x", Fold::x, true},
    {"xy", Fold::xy, true},
};

}  // namespace

size_t frame_bytes(const SceneData& data, const RenderResult& r, size_t pixels) {
  return data.blas.nodes.size() * sizeof(rf_node) + data.blas.tris.size() * sizeof(rf_tri) +
         data.normal_xforms.size() * sizeof(rf_normal_xform) + r.tlas_nodes * sizeof(rf_node) +
         r.instances * sizeof(rf_instance) + r.rays * sizeof(uint32_t) + pixels * sizeof(rf_pixel_hit);
}

std::string fmt(const char* f, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, v);
  return buf;
}

bool BenchReport::exact() const {
  for (const BenchRow& r : rows)
    if (r.mismatched_pixels) return false;
  return true;
}

std::vector<CameraSpec> camera_path(const CameraSpec& base, int views) {
  std::vector<CameraSpec> path;
  for (int k = 0; k < views; ++k) {
    const double s = views > 1 ? static_cast<double>(k) / (views - 1) * 2.0 - 1.0 : 0.0;  // -1 .. 1
    CameraSpec c = base;
    const glm::dvec3 offset = base.eye - base.look_at;
    const glm::dmat4 turn = glm::rotate(glm::dmat4(1.0), glm::radians(20.0 * s), glm::dvec3(0.0, 1.0, 0.0));
    c.eye = base.look_at + glm::dvec3(turn * glm::dvec4(offset, 0.0)) * (1.0 + 0.1 * s * s - 0.05);
    path.push_back(c);
  }
  return path;
}

std::vector<CameraSpec> camera_path(const Scene& scene, const ViewPath& p) {
  if (p.random) {
    if (scene.world_bounds().empty()) throw InputError(p.scene, "--random-views: the scene has no geometry to look at");
    PipelineOptions ro;
    ro.backend = Backend::cpu;
    Pipeline cpu(scene, ro);
    const RandomViews rv = random_views(scene, cpu, p.views, p.seed, p.kind);
    p.views_note = std::to_string(p.views) + " random " + view_kind_name(rv.kind) + " views, seed " +
                   std::to_string(p.seed) + " (tools/fixtures/random_views.h; " + std::to_string(rv.redrawn) + " drawn again";
    if (rv.below_threshold) p.views_note += ", " + std::to_string(rv.below_threshold) + " below its threshold";
    p.views_note += ")";
    return rv.cameras;
  }
  CameraSpec base = scene.camera ? *scene.camera : frame_bounds(scene.world_bounds());
  if (p.eye) {
    base.eye = *p.eye;
    base.look_at = *p.look_at;
    base.up = glm::dvec3(0.0, 1.0, 0.0);
  }
  return camera_path(base, p.views);
}

bool parse_view_path_option(const std::string& a, cli::Args& args, ViewPath& p, bool* have_scene) {
  if (a == "--size") {
    cli::parse_size(a, args.value(a), &p.width, &p.height);
  } else if (a == "--views") {
    p.views = cli::parse_int(a, args.value(a), 1, 1000);
  } else if (a == "--frames") {
    p.frames = cli::parse_int(a, args.value(a), 1, 100000);
  } else if (a == "--warmup") {
    p.warmup = cli::parse_int(a, args.value(a), 0, 1000);
  } else if (a == "--eye") {
    p.eye = cli::parse_vec3(a, args.value(a));
  } else if (a == "--look-at") {
    p.look_at = cli::parse_vec3(a, args.value(a));
  } else if (a == "--random-views") {
    p.views = cli::parse_int(a, args.value(a), 1, 1000);
    p.random = true;
  } else if (a == "--seed") {
    p.seed = static_cast<uint64_t>(cli::parse_int(a, args.value(a), 0, 2147483647));
    p.seed_given = true;
  } else if (a == "--view-kind") {
    p.kind = parse_view_kind(a, args.value(a));
  } else if (!a.empty() && a[0] != '-') {
    if (*have_scene) throw UsageError("more than one scene given ('" + p.scene + "' and '" + a + "')");
    p.scene = a;
    *have_scene = true;
  } else {
    return false;
  }
  return true;
}

void check_view_path(const ViewPath& p) {
  if (p.eye.has_value() != p.look_at.has_value()) throw UsageError("--eye and --look-at go together");
  if (p.random && p.eye) throw UsageError("--random-views draws its own views: drop --eye and --look-at");
  if (!p.random && (p.seed_given || p.kind != ViewKind::automatic))
    throw UsageError("--seed and --view-kind choose random views: add --random-views N");
}

BenchReport run_bench(const BenchOptions& opt, const std::function<void(size_t, size_t)>& progress) {
  const Scene scene = load_gltf(opt.scene);
  const std::vector<CameraSpec> path = camera_path(scene, opt);
  PipelineOptions renderer_options = opt.renderer;
  if (opt.animate) renderer_options.merge.dynamic = animated_instances(scene.instances.size());
  Pipeline renderer(scene, renderer_options);

  BenchReport rep;
  rep.scene = opt.scene;
  rep.device = renderer.device_name();
  rep.machine = read_machine_info();
  rep.tile_lanes = renderer.tile_lanes();
  rep.width = opt.width;
  rep.height = opt.height;
  rep.views = opt.views;
  rep.views_note = opt.views_note;
  rep.frames = opt.frames;
  rep.warmup = opt.warmup;
  rep.animate = opt.animate;
  rep.threads = resolve_threads(opt.renderer.threads);
  rep.instances = scene.instances.size();
  rep.meshes = scene.meshes.size();
  rep.triangles = scene.triangle_count();
  rep.prebuild_ms = renderer.blas_build_ms();
  for (const Method& m : kMethods) rep.rows.push_back({m.name, m.fold, m.cull});

  const size_t pixels = static_cast<size_t>(opt.width) * opt.height;
  const size_t total = static_cast<size_t>(opt.views) * rep.rows.size() * static_cast<size_t>(opt.warmup + opt.frames);
  size_t done = 0;
  auto tick = [&](size_t n) {
    done += n;
    if (progress) progress(done, total);
  };
  for (int v = 0; v < opt.views; ++v) {
    const Camera cam = make_camera(path[v], opt.width, opt.height);
    auto options = [&](const BenchRow& row, int frame) {
      FrameOptions fo;
      fo.fold = row.fold;
      fo.cull = row.cull;
      fo.animate_frame = opt.animate ? frame : -1;
      return fo;
    };
    for (BenchRow& row : rep.rows) {
      if (opt.warmup > 0) renderer.render(cam, opt.warmup, options(row, 0));
      tick(static_cast<size_t>(opt.warmup));
    }
    // Methods take turns frame by frame, so that the drift of a noisy
    // machine affects them alike (the renderer keeps every mode's ray list).
    std::vector<std::vector<double>> t(rep.rows.size()), tr(rep.rows.size()), up(rep.rows.size());
    std::vector<RenderResult> results(rep.rows.size());  // hit buffers reused frame to frame
    for (int f = 0; f < opt.frames; ++f) {
      for (size_t mi = 0; mi < rep.rows.size(); ++mi) {
        BenchRow& row = rep.rows[mi];
        RenderResult& r = results[mi];
        renderer.render_into(r, cam, 1, options(row, f));
        const FrameTimes& ft = r.frames[0];
        t[mi].push_back(ft.ray_list_ms + ft.trace_ms + ft.readback_ms);
        tr[mi].push_back(ft.trace_ms);
        up[mi].push_back(ft.cull_ms + ft.tlas_ms + ft.upload_ms);
        if (f == 0) {
          row.rays += static_cast<double>(r.rays) / opt.views;
          row.instances += static_cast<double>(r.instances) / opt.views;
          row.memory_bytes = std::max(row.memory_bytes, frame_bytes(renderer.scene_data(), r, pixels));
        }
        if (mi > 0) row.mismatched_pixels += count_differing_pixels(results[0].hits, r.hits);
        tick(1);
      }
    }
    for (size_t mi = 0; mi < rep.rows.size(); ++mi) {
      rep.rows[mi].render_ms += median(t[mi]) / opt.views;
      rep.rows[mi].trace_ms += median(tr[mi]) / opt.views;
      rep.rows[mi].update_ms += median(up[mi]) / opt.views;
    }
  }
  rep.kernel = renderer.kernel_label();  // after the frames: a measured choice is made on the first
  return rep;
}

std::string bench_markdown(const BenchReport& r) {
  std::ostringstream s;
  const BenchRow& none = r.rows[1];
  const double pixels = static_cast<double>(r.width) * r.height;
  s << "Scene `" << r.scene << "`: " << r.instances << " instances, " << r.meshes << " meshes, " << r.triangles
    << " triangles; " << r.width << "x" << r.height << ", " << r.views << " views, median of " << r.frames
    << " frames after " << r.warmup << " warm-up" << (r.animate ? ", animated" : "") << ".\n";
  if (!r.views_note.empty()) s << "Views: " << r.views_note << ".\n";
  s << "Machine: " << machine_label(r.machine) << ".\n";
  s << "Device: " << r.device << ", " << r.kernel << " kernel";
  if (r.kernel == "tile" && r.tile_lanes) s << ", " << r.tile_lanes << " lanes";
  s << " (" << r.threads << " host threads). Folded output "
    << (r.exact() ? "equals the unfolded output bit for bit in every view."
                  : "DIFFERS from the unfolded output (see mismatched pixels).")
    << "\n\n";
  s << "Table 1 - render time T (ray list + trace + readback) and device memory M\n\n";
  s << "| method (flip) | T ms | T ratio to none | trace ms | Mpixels/s | rays/frame | Mrays/s | instances | M MB | "
       "M ratio | mismatched pixels |\n";
  s << "|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const BenchRow& row : r.rows) {
    s << "| " << row.method << " | " << fmt("%.1f", row.render_ms) << " | "
      << fmt("%.2fx", none.render_ms / row.render_ms) << " | " << fmt("%.1f", row.trace_ms) << " | "
      << fmt("%.1f", pixels / (row.render_ms * 1e3)) << " | " << fmt("%.0f", row.rays) << " | "
      << fmt("%.1f", row.rays / (row.trace_ms * 1e3)) << " | " << fmt("%.0f", row.instances) << " | "
      << fmt("%.4f", row.memory_bytes / 1048576.0) << " | "
      << fmt("%.4f", static_cast<double>(row.memory_bytes) / static_cast<double>(none.memory_bytes)) << " | "
      << row.mismatched_pixels << " |\n";
  }
  s << "\nTable 2 - BVH pre-build (all bottom-level trees) and per-frame update (culling + top-level build + "
       "upload)\n\n";
  s << "| method (flip) | pre-build ms | update ms | update ratio to none |\n|---|---|---|---|\n";
  for (const BenchRow& row : r.rows)
    s << "| " << row.method << " | " << fmt("%.1f", r.prebuild_ms) << " | " << fmt("%.3f", row.update_ms) << " | "
      << fmt("%.2fx", row.update_ms / none.update_ms) << " |\n";
  s << "\nRatios: T and update are 'none / method' for speed (above 1 is faster) and 'method / none' for the "
       "update cost; M ratio is 'method / none'.\n";
  return s.str();
}

std::string bench_json(const BenchReport& r) {
  nlohmann::json j;
  j["scene"] = r.scene;
  j["device"] = r.device;
  j["machine"] = {{"cpu", r.machine.cpu_model}, {"isa", r.machine.isa}, {"tile_lanes", r.tile_lanes}};
  j["kernel"] = r.kernel;
  j["threads"] = r.threads;
  j["width"] = r.width;
  j["height"] = r.height;
  j["views"] = r.views;
  j["views_note"] = r.views_note;
  j["frames"] = r.frames;
  j["warmup"] = r.warmup;
  j["animate"] = r.animate;
  j["instances"] = r.instances;
  j["meshes"] = r.meshes;
  j["triangles"] = r.triangles;
  j["prebuild_ms"] = r.prebuild_ms;
  j["exact"] = r.exact();
  for (const BenchRow& row : r.rows) {
    j["methods"].push_back({{"method", row.method},
                            {"fold", fold_name(row.fold)},
                            {"cull", row.cull},
                            {"render_ms", row.render_ms},
                            {"trace_ms", row.trace_ms},
                            {"update_ms", row.update_ms},
                            {"memory_bytes", row.memory_bytes},
                            {"rays_per_frame", row.rays},
                            {"instances", row.instances},
                            {"mismatched_pixels", row.mismatched_pixels}});
  }
  return j.dump(2) + "\n";
}

}  // namespace rayfold::core
