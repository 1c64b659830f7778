#include "bench/bench_align.h"

#include <cstdio>
#include <memory>
#include <sstream>

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "fold/view_passes.h"
#include "reference/hit_compare.h"
#include "scene/gltf_loader.h"
#include "util/parallel.h"
#include "util/timer.h"

namespace rayfold::core {
namespace {

// What one way of tracing a list of views costs per frame: every pass's
// times summed, medians over frames.
struct Measured {
  double render_ms = 0.0, trace_ms = 0.0, update_ms = 0.0;
  size_t bytes = 0, instances = 0;
  std::vector<HitBuffer> hits;  // per view, of the last frame
};

// One frame of every pass; the hits kept when asked (they are large).
Measured one_frame(Pipeline& renderer, const std::vector<Camera>& views, const std::vector<std::vector<size_t>>& passes,
                   Fold fold, RenderResult& r, bool keep_hits) {
  Measured m;
  if (keep_hits) m.hits.resize(views.size());
  FrameOptions fo;
  fo.fold = fold;
  for (const std::vector<size_t>& pass : passes) {
    std::vector<Camera> cams;
    for (size_t i : pass) cams.push_back(views[i]);
    renderer.render_views_into(r, cams, 1, fo);
    m.render_ms += r.median.trace_ms + r.median.readback_ms + r.median.ray_list_ms;
    m.trace_ms += r.median.trace_ms;
    m.update_ms += r.median.cull_ms + r.median.tlas_ms + r.median.upload_ms;
    m.bytes = std::max(m.bytes, frame_bytes(renderer.scene_data(), r, r.hits.size()));
    m.instances += r.instances;
    if (keep_hits)
      for (size_t k = 0; k < pass.size(); ++k) m.hits[pass[k]] = view_result(r, k).hits;
  }
  return m;
}

// Medians over frames.
Measured median_of(const std::vector<Measured>& ms) {
  Measured out = ms.back();
  std::vector<double> render, trace, update;
  for (const Measured& m : ms) {
    render.push_back(m.render_ms);
    trace.push_back(m.trace_ms);
    update.push_back(m.update_ms);
  }
  out.render_ms = median(render);
  out.trace_ms = median(trace);
  out.update_ms = median(update);
  return out;
}

// The tile kernel's counters over the passes, one stats-built tracer.
TileCounters count_tiles(ClTracer& tracer, const Scene& scene, const SceneData& data, const std::vector<Camera>& views,
                         const std::vector<std::vector<size_t>>& passes, Fold fold) {
  TileCounters c;
  for (const std::vector<size_t>& pass : passes) {
    std::vector<Camera> cams;
    for (size_t i : pass) cams.push_back(views[i]);
    const Fold traced = restrict_fold(fold, can_fold_columns(cams[0]), can_fold_rows(cams[0]));
    const RayList rays = make_ray_list(cams[0].params, traced);
    FrameOptions fo;
    fo.fold = traced;
    const Frame frame = build_frame(scene, data, cams, rays, fo);
    const size_t pixels = rays.pixels * cams.size();
    tracer.upload_scene(data, frame.tlas_nodes.size(), frame.instances.size(), rays.entries.size(), pixels);
    tracer.upload_frame(frame);
    tracer.upload_rays(rays);
    std::vector<rf_pixel_hit> out(pixels);
    tracer.bind_output(out.data(), pixels);
    tracer.trace(frame_camera(cams[0], frame), KernelKind::tile);
    tracer.read_hits(out.data(), pixels);
    const std::vector<uint32_t> st = tracer.read_tile_stats();
    for (size_t i = 0; i < st.size(); ++i) {
      const double v = st[i];
      switch (i % RF_TILE_STAT_COUNT) {
        case RF_TILE_STAT_TLAS_NODES: c.tlas_nodes += v; break;
        case RF_TILE_STAT_INSTANCES: c.instances += v; break;
        case RF_TILE_STAT_SETUPS: c.setups += v; break;
        case RF_TILE_STAT_BLAS_NODES: c.blas_nodes += v; break;
        case RF_TILE_STAT_TRI_LANES: c.tri_lanes += v; break;
        default: break;
      }
    }
  }
  const double n = static_cast<double>(views.size());
  c.tlas_nodes /= n;
  c.instances /= n;
  c.setups /= n;
  c.blas_nodes /= n;
  c.tri_lanes /= n;
  return c;
}

}  // namespace

bool AlignReport::exact() const {
  for (const AlignRow& r : rows)
    if (r.mismatched_pixels) return false;
  return true;
}

AlignReport run_align_bench(const AlignBenchOptions& opt, const std::function<void(size_t, size_t)>& progress) {
  const Scene scene = load_gltf(opt.scene);
  ViewPath one = opt;
  one.views = 1;
  const CameraSpec base = camera_path(scene, one)[0];

  // The kernels compared: both OpenCL kernels unless one is asked for.
  struct Way {
    std::string label;
    std::unique_ptr<Pipeline> renderer;
  };
  std::vector<Way> ways;
  auto add_way = [&](Kernel k) {
    PipelineOptions o = opt.renderer;
    o.kernel = k;
    auto r = std::make_unique<Pipeline>(scene, o);
    ways.push_back({r->kernel_label(), std::move(r)});
  };
  if (opt.renderer.backend == Backend::cpu || opt.renderer.kernel == Kernel::tile ||
      opt.renderer.kernel == Kernel::single) {
    add_way(opt.renderer.kernel);
  } else {
    add_way(Kernel::tile);
    add_way(Kernel::single);
  }
  const SceneData& data = ways[0].renderer->scene_data();
  std::unique_ptr<ClDevice> stats_device;
  std::unique_ptr<ClTracer> stats_tracer;
  if (opt.renderer.backend == Backend::opencl) {
    stats_device = std::make_unique<ClDevice>(opt.renderer.device_hint);
    stats_tracer = std::make_unique<ClTracer>(*stats_device, opt.renderer.precision, true);
  }

  AlignReport rep;
  rep.scene = opt.scene;
  rep.device = ways[0].renderer->device_name();
  rep.width = opt.width;
  rep.height = opt.height;
  rep.frames = opt.frames;
  rep.warmup = opt.warmup;
  rep.threads = resolve_threads(opt.renderer.threads);
  rep.instances = scene.instances.size();
  rep.triangles = scene.triangle_count();
  rep.baseline = opt.baseline > 0.0 ? opt.baseline : 0.0032 * glm::length(glm::dvec3(scene.world_bounds().extent()));

  struct Scenario {
    std::string name;
    std::vector<Camera> views;
  };
  std::vector<Scenario> scenarios;
  {
    const glm::dvec3 right(make_camera(base, 8, 8).world_from_camera[0]);
    Scenario s{"stereo", {}};
    for (double sign : {-0.5, 0.5}) {
      CameraSpec e = base;
      e.eye += sign * rep.baseline * right;
      e.look_at += sign * rep.baseline * right;
      s.views.push_back(make_camera(e, opt.width, opt.height));
    }
    scenarios.push_back(s);
  }
  for (int n : opt.counts) {
    Scenario s{"path", {}};
    for (const CameraSpec& c : camera_path(base, n)) s.views.push_back(make_camera(c, opt.width, opt.height));
    scenarios.push_back(s);
  }

  size_t total = 0, done = 0;
  for (const Scenario& s : scenarios) total += 2 * ways.size() * opt.folds.size() * s.views.size();
  auto tick = [&] {
    if (progress) progress(++done, total);
  };
  for (const Scenario& s : scenarios) {
    std::vector<std::vector<size_t>> alone;
    for (size_t i = 0; i < s.views.size(); ++i) alone.push_back({i});
    // The model's predictions first, for every choice measured below.
    std::vector<Choice> choices;
    for (Fold fold : opt.folds)
      for (const Way& w : ways)
        for (int align : {1, RF_GROUP_LIMIT})
          choices.push_back({fold, w.label == "single" ? KernelKind::single : KernelKind::tile, align});
    const std::vector<Prediction> predicted = ways[0].renderer->predict(s.views, choices);
    // What --fold auto --align auto would pick (choose_fastest: the kernels
    // first, then every fold and alignment of those kept), and its cost.
    std::vector<KernelKind> kernels;
    for (const Way& w : ways) kernels.push_back(w.label == "single" ? KernelKind::single : KernelKind::tile);
    const AutoChoice chosen = choose_fastest(*ways[0].renderer, s.views, opt.folds, kernels, {1, RF_GROUP_LIMIT});
    AutoCheck check;
    check.scenario = s.name;
    check.views = static_cast<int>(s.views.size());
    check.probe_ms = chosen.probe_ms;
    size_t pick = predicted.size();
    for (size_t k = 0; k < predicted.size(); ++k)
      if (choice_name(predicted[k].choice) == choice_name(chosen.best)) pick = k;
    check.picked = choice_name(chosen.best);
    // Every choice measured frame by frame in turn (alone and aligned, every
    // fold and kernel), so that a slow spell of a shared machine hits them
    // alike; each figure the median over frames.
    struct Cell {
      Fold fold;
      Way* way;
      std::vector<std::vector<size_t>> aligned;
      TileCounters alone_counts, aligned_counts;
      std::vector<Measured> a, b;
      size_t mismatched = 0;  // aligned against alone, the last frame, every view
    };
    std::vector<Cell> cells;
    for (Fold fold : opt.folds) {
      Cell base{fold, nullptr, plan_passes(data, s.views, RF_GROUP_LIMIT, fold), {}, {}, {}, {}, 0};
      if (stats_tracer) {
        base.alone_counts = count_tiles(*stats_tracer, scene, data, s.views, alone, fold);
        base.aligned_counts = count_tiles(*stats_tracer, scene, data, s.views, base.aligned, fold);
      }
      for (Way& w : ways) {
        cells.push_back(base);
        cells.back().way = &w;
      }
    }
    RenderResult scratch;
    for (int f = 0; f < opt.warmup + opt.frames; ++f) {
      const bool measured = f >= opt.warmup, last = f + 1 == opt.warmup + opt.frames;
      for (Cell& c : cells) {
        Measured a = one_frame(*c.way->renderer, s.views, alone, c.fold, scratch, last);
        Measured b = one_frame(*c.way->renderer, s.views, c.aligned, c.fold, scratch, last);
        if (last) {  // compared now: every cell's hits together would not fit in memory
          for (size_t v = 0; v < s.views.size(); ++v) c.mismatched += count_differing_pixels(a.hits[v], b.hits[v]);
          a.hits.clear();
          b.hits.clear();
        }
        if (measured) {
          c.a.push_back(std::move(a));
          c.b.push_back(std::move(b));
        }
      }
    }
    double picked_measured = -1.0, best = 1e300;
    size_t next_prediction = 0;
    for (Cell& c : cells) {
      for (size_t k = 0; k < 2 * s.views.size(); ++k) tick();
      const Measured a = median_of(c.a), b = median_of(c.b);
      AlignRow row;
      row.scenario = s.name;
      row.views = static_cast<int>(s.views.size());
      row.fold = c.fold;
      row.kernel = c.way->label;
      row.passes = static_cast<int>(c.aligned.size());
      const double n = static_cast<double>(s.views.size());
      row.alone_ms = a.render_ms / n;
      row.aligned_ms = b.render_ms / n;
      row.alone_update_ms = a.update_ms / n;
      row.aligned_update_ms = b.update_ms / n;
      row.alone_bytes = a.bytes;
      row.aligned_bytes = b.bytes;
      row.alone_instances = static_cast<double>(a.instances) / n;
      row.aligned_instances = static_cast<double>(b.instances) / n;
      row.alone_measured_ms = (a.trace_ms + a.update_ms) / n;
      row.aligned_measured_ms = (b.trace_ms + b.update_ms) / n;
      row.alone_predicted_ms = predicted[next_prediction].total_ms();
      row.aligned_predicted_ms = predicted[next_prediction + 1].total_ms();
      for (size_t k = 0; k < 2; ++k) {
        const double m = k == 0 ? row.alone_measured_ms : row.aligned_measured_ms;
        if (next_prediction + k == pick) picked_measured = m;
        if (m < best) {
          best = m;
          check.best = choice_name(predicted[next_prediction + k].choice);
        }
      }
      next_prediction += 2;
      if (c.way->label == "tile") {
        row.alone_counts = c.alone_counts;
        row.aligned_counts = c.aligned_counts;
      }
      row.mismatched_pixels = c.mismatched;
      rep.rows.push_back(row);
    }
    check.picked_ms = picked_measured;
    check.best_ms = best;
    rep.autos.push_back(check);
  }
  return rep;
}

std::string align_markdown(const AlignReport& r) {
  std::ostringstream o;
  o << "# rayfold bench --align: " << r.scene << "\n\n";
  o << r.width << "x" << r.height << ", " << r.device << ", " << r.threads << " threads, " << r.instances
    << " instances, " << r.triangles << " triangles; medians of " << r.frames << " frames after " << r.warmup
    << " warm-up; stereo baseline " << fmt("%.4g", r.baseline)
    << " world units. Every aligned view equals the same view alone bit for bit: " << (r.exact() ? "yes" : "NO")
    << ".\n\n";
  o << "| views | fold | kernel | passes | alone ms/view | aligned ms/view | speed-up | update alone / aligned "
       "ms/view | memory alone / aligned MiB | TLAS items/view alone / aligned | tile: TLAS nodes, instances, "
       "set-ups, BLAS nodes per view, alone -> aligned | mismatched |\n";
  o << "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const AlignRow& row : r.rows) {
    o << "| " << row.scenario << " " << row.views << " | " << fold_name(row.fold) << " | " << row.kernel << " | "
      << row.passes << " | " << fmt("%.2f", row.alone_ms) << " | " << fmt("%.2f", row.aligned_ms) << " | "
      << fmt("%.2fx", row.speedup()) << " | " << fmt("%.2f", row.alone_update_ms) << " / "
      << fmt("%.2f", row.aligned_update_ms) << " | " << fmt("%.1f", row.alone_bytes / 1048576.0) << " / "
      << fmt("%.1f", row.aligned_bytes / 1048576.0) << " | " << fmt("%.0f", row.alone_instances) << " / "
      << fmt("%.0f", row.aligned_instances) << " | ";
    if (row.kernel == "tile")
      o << fmt("%.0f", row.alone_counts.tlas_nodes) << ", " << fmt("%.0f", row.alone_counts.instances) << ", "
        << fmt("%.0f", row.alone_counts.setups) << ", " << fmt("%.0f", row.alone_counts.blas_nodes) << " -> "
        << fmt("%.0f", row.aligned_counts.tlas_nodes) << ", " << fmt("%.0f", row.aligned_counts.instances) << ", "
        << fmt("%.0f", row.aligned_counts.setups) << ", " << fmt("%.0f", row.aligned_counts.blas_nodes);
    else
      o << "-";
    o << " | " << row.mismatched_pixels << " |\n";
  }
  o << "\n## The cost model (docs/cost_model.md): predicted against measured, trace + update ms per view\n\n";
  o << "| views | fold | kernel | alone predicted / measured | error | aligned predicted / measured | error | "
       "predicted speed-up / measured |\n|---|---|---|---|---|---|---|---|\n";
  auto err = [](double p, double m) { return m > 0.0 ? fmt("%+.0f%%", 100.0 * (p - m) / m) : std::string("-"); };
  for (const AlignRow& row : r.rows) {
    o << "| " << row.scenario << " " << row.views << " | " << fold_name(row.fold) << " | " << row.kernel << " | "
      << fmt("%.2f", row.alone_predicted_ms) << " / " << fmt("%.2f", row.alone_measured_ms) << " | "
      << err(row.alone_predicted_ms, row.alone_measured_ms) << " | " << fmt("%.2f", row.aligned_predicted_ms) << " / "
      << fmt("%.2f", row.aligned_measured_ms) << " | " << err(row.aligned_predicted_ms, row.aligned_measured_ms)
      << " | " << fmt("%.2fx", row.alone_predicted_ms / row.aligned_predicted_ms) << " / "
      << fmt("%.2fx", row.alone_measured_ms / row.aligned_measured_ms) << " |\n";
  }
  o << "\n## auto: the choice of least predicted time, measured\n\n";
  o << "| views | auto picks | its measured ms/view | best measured | its ms/view | auto / best | probe ms |\n"
       "|---|---|---|---|---|---|---|\n";
  for (const AutoCheck& a : r.autos)
    o << "| " << a.scenario << " " << a.views << " | " << a.picked << " | " << fmt("%.2f", a.picked_ms) << " | "
      << a.best << " | " << fmt("%.2f", a.best_ms) << " | " << fmt("%.2fx", a.picked_ms / a.best_ms) << " | "
      << fmt("%.1f", a.probe_ms) << " |\n";
  return o.str();
}

std::string align_json(const AlignReport& r) {
  nlohmann::json j;
  j["scene"] = r.scene;
  j["device"] = r.device;
  j["width"] = r.width;
  j["height"] = r.height;
  j["frames"] = r.frames;
  j["warmup"] = r.warmup;
  j["threads"] = r.threads;
  j["baseline"] = r.baseline;
  j["exact"] = r.exact();
  auto counts = [](const TileCounters& c) {
    return nlohmann::json{{"tlas_nodes", c.tlas_nodes},
                          {"instances", c.instances},
                          {"setups", c.setups},
                          {"blas_nodes", c.blas_nodes},
                          {"triangle_lanes", c.tri_lanes}};
  };
  for (const AlignRow& row : r.rows)
    j["rows"].push_back({{"scenario", row.scenario},
                         {"views", row.views},
                         {"fold", fold_name(row.fold)},
                         {"kernel", row.kernel},
                         {"passes", row.passes},
                         {"alone_ms_per_view", row.alone_ms},
                         {"aligned_ms_per_view", row.aligned_ms},
                         {"speedup", row.speedup()},
                         {"alone_update_ms_per_view", row.alone_update_ms},
                         {"aligned_update_ms_per_view", row.aligned_update_ms},
                         {"alone_bytes", row.alone_bytes},
                         {"aligned_bytes", row.aligned_bytes},
                         {"alone_tlas_items_per_view", row.alone_instances},
                         {"aligned_tlas_items_per_view", row.aligned_instances},
                         {"alone_tile_counters_per_view", counts(row.alone_counts)},
                         {"aligned_tile_counters_per_view", counts(row.aligned_counts)},
                         {"mismatched_pixels", row.mismatched_pixels},
                         {"alone_predicted_ms_per_view", row.alone_predicted_ms},
                         {"aligned_predicted_ms_per_view", row.aligned_predicted_ms},
                         {"alone_measured_ms_per_view", row.alone_measured_ms},
                         {"aligned_measured_ms_per_view", row.aligned_measured_ms}});
  for (const AutoCheck& a : r.autos)
    j["auto"].push_back({{"scenario", a.scenario},
                         {"views", a.views},
                         {"picked", a.picked},
                         {"picked_ms_per_view", a.picked_ms},
                         {"best", a.best},
                         {"best_ms_per_view", a.best_ms},
                         {"probe_ms", a.probe_ms}});
  return j.dump(2);
}

}  // namespace rayfold::core
