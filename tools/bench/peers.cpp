#include "bench/peers.h"

#include <algorithm>
#include <cstdio>
#include <iterator>
#include <memory>
#include <optional>
#include <sstream>

#include <nlohmann/json.hpp>

#include "bench/bench.h"
#include "bench/embree_peer.h"
#include "opencl/cl_device.h"
#include "opencl/kernel_cache.h"
#include "bench/peak_memory.h"
#include "reference/double_reference.h"
#include "reference/hit_compare.h"
#include "pipeline/pipeline.h"
#include "scene/gltf_loader.h"
#include "util/errors.h"
#include "util/large_pages.h"
#include "util/timer.h"

namespace rayfold::core {
namespace {

struct Accumulator {
  explicit Accumulator(PeerRow r) : row(std::move(r)) {}
  PeerRow row;
  std::vector<double> medians;
  int views = 0;
  void add(double ms, size_t rays, size_t pixels, const Accuracy& a, int total_views) {
    row.ms += ms / total_views;
    row.rays += static_cast<double>(rays) / total_views;
    row.pixels += static_cast<double>(pixels) / total_views;
    row.accuracy.same_hit += a.same_hit / total_views;
    row.accuracy.hit_miss += a.hit_miss / total_views;
    row.accuracy.depth_p99 = std::max(row.accuracy.depth_p99, a.depth_p99);
    row.accuracy.depth_max = std::max(row.accuracy.depth_max, a.depth_max);
    medians.push_back(a.depth_median);
  }
  PeerRow finish() {
    row.accuracy.depth_median = median(medians);
    return row;
  }
};

PeerRow make_row(const std::string& variant, const std::string& fold) {
  PeerRow r;
  r.variant = variant;
  r.fold = fold;
  return r;
}

}  // namespace

PeerReport run_peers(const PeerOptions& opt) {
  // The drivers load while the scene is read, as `rayfold render` does.
  std::optional<OpenClPreload> preload;
  if (opt.variants.size() > opt.variants.count("cpu")) preload.emplace();
  const auto load_start = Clock::now();
  LoadOptions load;
  load.threads = opt.threads;
  const Scene scene = load_gltf(opt.scene, nullptr, load);
  const double load_ms = ms_since(load_start);
  const std::vector<CameraSpec> path = camera_path(scene, opt);

  struct Ours {
    const char* key;  // as --variants names it
    const char* name;
    Backend backend;
    Kernel kernel;
    KernelPrecision precision;
    bool exact_depth;  // FrameOptions::exact_depth
    unsigned lanes;    // KernelTuning::tile_lanes (0: the device's)
    bool ab;           // built with PeerOptions::ab_defines as well
  };
  const Ours all_ours[] = {
      {"tile", "OpenCL tile", Backend::opencl, Kernel::tile, KernelPrecision::exact, false, 0, false},
      {"tile8", "OpenCL tile 8 lanes", Backend::opencl, Kernel::tile, KernelPrecision::exact, false, 8, false},
      {"tile16", "OpenCL tile 16 lanes", Backend::opencl, Kernel::tile, KernelPrecision::exact, false, 16, false},
      {"tile-ab", "OpenCL tile with the A/B defines", Backend::opencl, Kernel::tile, KernelPrecision::exact,
       false, 0, true},
      {"single", "OpenCL single", Backend::opencl, Kernel::single, KernelPrecision::exact, false, 0, false},
      {"fast", "OpenCL tile fast", Backend::opencl, Kernel::tile, KernelPrecision::fast, false, 0, false},
      {"exact-depth", "OpenCL tile exact depth", Backend::opencl, Kernel::tile, KernelPrecision::exact, true, 0,
       false},
      {"cpu", "CPU reference", Backend::cpu, Kernel::automatic, KernelPrecision::exact, false, 0, false}};
  // The CPU reference renderer always exists (it validates every exact row);
  // its rows are timed only when asked for.
  std::vector<Ours> ours;
  for (const Ours& o : all_ours)
    if (o.backend == Backend::cpu || opt.variants.count(o.key)) ours.push_back(o);
  const bool time_cpu = opt.variants.count("cpu") != 0;
  const Fold folds[] = {Fold::none, Fold::y, Fold::x, Fold::xy};
  std::vector<std::unique_ptr<Pipeline>> renderers;
  double first_renderer_ms = 0.0;
  bool first_kernels_cached = false;
  for (const Ours& o : ours) {
    PipelineOptions ro;
    ro.backend = o.backend;
    ro.kernel = o.kernel;
    ro.precision = o.precision;
    ro.threads = opt.threads;
    ro.device_hint = opt.device_hint;
    ro.merge.enabled = opt.merge;
    ro.tuning.tile_lanes = o.lanes;
    if (o.ab) ro.tuning.defines = opt.ab_defines;
    const auto start = Clock::now();
    const size_t cache_hits = kernel_cache_hits();
    renderers.push_back(std::make_unique<Pipeline>(scene, ro));
    if (renderers.size() == 1) {
      first_renderer_ms = ms_since(start);
      first_kernels_cached = kernel_cache_hits() > cache_hits;
    }
  }
  const SceneData& data = renderers[0]->scene_data();
  const size_t timed_renderers = time_cpu ? renderers.size() : renderers.size() - 1;

  PeerReport rep;
  rep.scene = opt.scene;
  rep.device = renderers[0]->device_name();
  rep.machine = read_machine_info();
  for (size_t r = 0; r < renderers.size() && rep.tile_lanes == 0; ++r)
    if (ours[r].kernel == Kernel::tile && ours[r].lanes == 0) rep.tile_lanes = renderers[r]->tile_lanes();
  rep.width = opt.width;
  rep.height = opt.height;
  rep.views = opt.views;
  rep.frames = opt.frames;
  rep.threads = opt.threads;
  rep.triangles = scene.triangle_count();
  rep.instances = scene.instances.size();
  rep.views_note = opt.views_note;
  rep.cameras = path;
  const double triangles = std::max<double>(1.0, static_cast<double>(rep.triangles));
  std::vector<double> rayfold_builds;
  {
    // The renderer's trees again, alone, for their time and peak memory
    // without the renderer's other set-up. Deterministic, so they are the
    // same trees. In fresh memory: blocks kept from the renderer's build
    // (util/large_pages.h) would hide this one's peak.
    release_kept_large_arrays();
    const PeakMemory memory;
    MergeOptions merge;
    merge.enabled = opt.merge;
    const SceneData again = prepare_scene(scene, opt.threads, BraidOptions{}, merge);
    rayfold_builds.push_back(again.blas.build_ms);
    rep.rayfold_build_bytes = static_cast<double>(memory.peak_bytes()) / triangles;
  }

  std::unique_ptr<EmbreePeer> embree, embree_avx2;
  std::vector<double> embree_builds, embree_high_builds;
  if (EmbreePeer::available()) {
    embree = std::make_unique<EmbreePeer>(scene, data, opt.threads);
    rep.embree_isa = embree->isa(rep.machine.isa);
    if (rep.embree_isa == "AVX-512") {
      try {
        embree_avx2 = std::make_unique<EmbreePeer>(scene, data, opt.threads, "avx2", true);
        rep.embree_avx2_note =
            "Embree flat AVX2: the default-quality flat scene on a device made with isa=avx2 "
            "(it traces with " +
            embree_avx2->isa(rep.machine.isa) + ")";
      } catch (const RuntimeFailure& e) {
        rep.embree_avx2_note = std::string("Embree forced to AVX2 is not timed: ") + e.what();
      }
    }
    embree_builds.push_back(embree->build_ms(EmbreeScene::flat));
    embree_high_builds.push_back(embree->build_ms(EmbreeScene::flat_high));
    rep.embree_build_bytes = static_cast<double>(embree->build_peak_bytes(EmbreeScene::flat)) / triangles;
    rep.embree_high_build_bytes = static_cast<double>(embree->build_peak_bytes(EmbreeScene::flat_high)) / triangles;
  } else
    rep.embree_note = "rayfold was built without Embree: its rows are skipped (install libembree-dev and reconfigure).";
  // More builds, rayfold's and Embree's alternated so that the machine's
  // drift hits them alike; the first of each above is the first round.
  for (int round = 1; round < opt.build_rounds; ++round) {
    MergeOptions merge;
    merge.enabled = opt.merge;
    rayfold_builds.push_back(prepare_scene(scene, opt.threads, BraidOptions{}, merge).blas.build_ms);
    if (!embree) continue;
    embree_builds.push_back(embree->rebuild_ms(EmbreeScene::flat));
    embree_high_builds.push_back(embree->rebuild_ms(EmbreeScene::flat_high));
  }
  rep.build_rounds = static_cast<int>(rayfold_builds.size());
  rep.rayfold_build_ms = median(rayfold_builds);
  if (embree) {
    rep.embree_build_ms = median(embree_builds);
    rep.embree_high_build_ms = median(embree_high_builds);
  }

  // Time to the first G-buffer of view 0: rayfold's load, renderer (trees,
  // device, programs) and first frame (its kernels' first launch included)
  // of the first timed variant, against Embree's default flat build and its
  // first rtcIntersect16 frame.
  if (!path.empty() && timed_renderers > 0) {
    const Camera cam = make_camera(path[0], opt.width, opt.height);
    // In fresh memory, as in a new process: the build rounds' freed arrays
    // (util/large_pages.h) would otherwise hold the frame's hits.
    release_kept_large_arrays();
    const auto start = Clock::now();
    renderers[0]->render(cam, 1, FrameOptions{});
    rep.rayfold_first_gbuffer = {load_ms, first_renderer_ms, ms_since(start), first_kernels_cached};
    if (embree) {
      embree->set_camera(cam);
      std::vector<rf_pixel_hit> hits;
      // Its first build, as rayfold's is its first: the median of the
      // rounds is of builds in a process that has built the scene before.
      rep.embree_first_gbuffer = {0.0, embree_builds.front(), embree->trace16(hits, EmbreeScene::flat)};
    }
  }

  std::vector<Accumulator> acc;
  for (size_t r = 0; r < timed_renderers; ++r)
    for (Fold f : folds) {
      acc.emplace_back(make_row(ours[r].name, fold_name(f)));
      acc.back().row.measurement_only = ours[r].ab;
    }
  const EmbreeScene embree_scenes[] = {EmbreeScene::instanced, EmbreeScene::flat, EmbreeScene::flat_high};
  const char* embree_names[] = {"Embree instanced", "Embree flat", "Embree flat high"};
  if (embree)
    for (const char* name : embree_names) {
      acc.emplace_back(make_row(std::string(name) + " rtcIntersect1", "-"));
      acc.emplace_back(make_row(std::string(name) + " rtcIntersect16", "-"));
    }
  if (embree_avx2)
    for (const char* name : {"Embree flat AVX2 rtcIntersect1", "Embree flat AVX2 rtcIntersect16"}) {
      acc.emplace_back(make_row(name, "-"));
      acc.back().row.measurement_only = true;
    }

  for (int v = 0; v < opt.views; ++v) {
    const Camera cam = make_camera(path[v], opt.width, opt.height);
    const std::vector<ReferenceHit> reference = trace_double_reference(scene, data, cam, opt.threads);
    // Exact variants are validated against the CPU reference's unfolded
    // image, bit for bit, before their figures count.
    const HitBuffer exact = renderers.back()->render(cam, 1, FrameOptions{}).hits;
    HitBuffer exact_depth;  // the same with the exact depth, when a variant has it
    for (size_t r = 0; r < timed_renderers; ++r)
      if (ours[r].exact_depth && exact_depth.empty()) {
        FrameOptions fo;
        fo.exact_depth = true;
        exact_depth = renderers.back()->render(cam, 1, fo).hits;
      }
    if (embree) embree->set_camera(cam);
    if (embree_avx2) embree_avx2->set_camera(cam);
    // Every variant once to warm up, then all take turns frame by frame, so
    // that the drift of a noisy machine affects them alike.
    const size_t rayfold_rows = timed_renderers * std::size(folds);
    std::vector<std::vector<double>> ms(acc.size());
    std::vector<RenderResult> last(rayfold_rows);
    std::vector<std::vector<rf_pixel_hit>> embree_hits(acc.size() - rayfold_rows);
    for (int f = -opt.warmup; f < opt.frames; ++f) {
      size_t a = 0;
      for (size_t r = 0; r < timed_renderers; ++r)
        for (Fold fold : folds) {
          FrameOptions fo;
          fo.fold = fold;
          fo.exact_depth = ours[r].exact_depth;
          RenderResult& res = last[a];  // its hit buffer is reused frame to frame
          renderers[r]->render_into(res, cam, 1, fo);
          if (f >= 0) ms[a].push_back(res.frames[0].ray_list_ms + res.frames[0].trace_ms + res.frames[0].readback_ms);
          ++a;
        }
      if (embree)
        for (EmbreeScene es : embree_scenes)
          for (int packets = 0; packets < 2; ++packets) {
            std::vector<rf_pixel_hit>& hits = embree_hits[a - rayfold_rows];
            const double t = packets ? embree->trace16(hits, es) : embree->trace1(hits, es);
            if (f >= 0) ms[a].push_back(t);
            ++a;
          }
      if (embree_avx2)
        for (int packets = 0; packets < 2; ++packets) {
          std::vector<rf_pixel_hit>& hits = embree_hits[a - rayfold_rows];
          const double t =
              packets ? embree_avx2->trace16(hits, EmbreeScene::flat) : embree_avx2->trace1(hits, EmbreeScene::flat);
          if (f >= 0) ms[a].push_back(t);
          ++a;
        }
    }
    size_t a = 0;
    for (size_t r = 0; r < timed_renderers; ++r)
      for (size_t k = 0; k < std::size(folds); ++k, ++a) {
        const RenderResult& res = last[a];
        if (ours[r].precision == KernelPrecision::exact) {
          acc[a].row.exact = true;
          acc[a].row.mismatched_pixels += count_differing_pixels(ours[r].exact_depth ? exact_depth : exact, res.hits);
        }
        acc[a].add(median(ms[a]), res.rays, res.hits.size(), measure_accuracy(reference, res.hits), opt.views);
      }
    for (; a < acc.size(); ++a) {
      const std::vector<rf_pixel_hit>& hits = embree_hits[a - rayfold_rows];
      acc[a].add(median(ms[a]), hits.size(), hits.size(), measure_accuracy(reference, hits), opt.views);
    }
  }
  for (Accumulator& x : acc) rep.rows.push_back(x.finish());
  return rep;
}

bool PeerReport::valid() const {
  for (const PeerRow& row : rows)
    if (row.exact && row.mismatched_pixels != 0) return false;
  return true;
}

namespace {
double mpixels(const PeerRow& r) { return r.pixels / (r.ms * 1e3); }
bool is_embree(const PeerRow& r) { return r.variant.rfind("Embree", 0) == 0; }
}  // namespace

PeerRatios peer_ratios(const PeerReport& rep) {
  PeerRatios q;
  auto faster = [](const PeerRow* best, const PeerRow& r) { return !best || mpixels(r) > mpixels(*best); };
  for (const PeerRow& r : rep.rows) {
    if (r.ms <= 0.0 || r.measurement_only) continue;
    if (is_embree(r)) {
      if (faster(q.fastest_embree, r)) q.fastest_embree = &r;
      if (r.variant.find("instanced") != std::string::npos && faster(q.fastest_embree_instanced, r))
        q.fastest_embree_instanced = &r;
    } else if (r.exact && r.variant.rfind("OpenCL", 0) == 0 && faster(q.fastest_rayfold, r)) {
      q.fastest_rayfold = &r;
    }
  }
  if (q.fastest_rayfold && q.fastest_embree) q.vs_embree = mpixels(*q.fastest_rayfold) / mpixels(*q.fastest_embree);
  if (q.fastest_rayfold && q.fastest_embree_instanced)
    q.vs_embree_instanced = mpixels(*q.fastest_rayfold) / mpixels(*q.fastest_embree_instanced);
  return q;
}

std::string peers_markdown(const PeerReport& r) {
  std::ostringstream s;
  s << "Scene `" << r.scene << "`: " << r.instances << " instances, " << r.triangles << " triangles; " << r.width << "x"
    << r.height << ", " << r.views << " views, median of " << r.frames << " frames; " << r.threads << " threads.\n";
  s << "Machine: " << machine_label(r.machine) << "; rayfold device: " << r.device;
  if (r.tile_lanes) s << ", tile kernel " << r.tile_lanes << " lanes";
  if (!r.embree_isa.empty()) s << "; Embree " << r.embree_isa;
  s << ".\n";
  if (!r.embree_avx2_note.empty()) s << r.embree_avx2_note << ".\n";
  if (!r.views_note.empty()) s << "Views: " << r.views_note << ".\n";
  if (!r.embree_note.empty()) s << r.embree_note << "\n";
  auto bytes = [](double b) { return b > 0.0 ? ", peak " + fmt("%.0f", b) + " B/scene triangle" : std::string(); };
  s << "Bottom-level build (median of " << r.build_rounds << ", rayfold's and Embree's alternated): rayfold "
    << fmt("%.0f", r.rayfold_build_ms) << " ms" << bytes(r.rayfold_build_bytes);
  if (r.embree_build_ms > 0.0)
    s << "; Embree flat " << fmt("%.0f", r.embree_build_ms) << " ms" << bytes(r.embree_build_bytes)
      << " (default quality), " << fmt("%.0f", r.embree_high_build_ms) << " ms" << bytes(r.embree_high_build_bytes)
      << " (high)";
  s << ". Peak: the resident set's high-water mark during the first build, less where it started.\n";
  const FirstGbuffer& a = r.rayfold_first_gbuffer;
  if (a.total() > 0.0) {
    s << "First G-buffer (view 0): rayfold " << fmt("%.0f", a.total()) << " ms (load " << fmt("%.0f", a.load_ms)
      << ", renderer " << fmt("%.0f", a.build_ms) << " with its kernels "
      << (a.kernels_cached ? "from rayfold's kernel cache" : "built") << ", first frame " << fmt("%.0f", a.frame_ms)
      << ")";
    const FirstGbuffer& e = r.embree_first_gbuffer;
    if (e.total() > 0.0)
      s << "; Embree flat " << fmt("%.0f", e.total()) << " ms (build " << fmt("%.0f", e.build_ms) << ", first frame "
        << fmt("%.0f", e.frame_ms) << "; its load not counted)";
    s << ".\n";
  }
  s << "\nTimes: rayfold per frame is ray list + trace + readback; Embree's is the trace and the same G-buffer "
       "(distance, unit world normal, barycentrics, ids) into host memory. "
       "Exact rows are checked bit for bit against the CPU reference's unfolded image first. "
       "Accuracy against the double-precision reference: share of pixels whose (instance, primitive) differs, "
       "hit/miss disagreements (included in the former), relative depth error where both hit the same triangle."
       "\n\n";
  s << "| variant | fold | ms/frame | Mrays/s | Mpixels/s | other triangle | hit/miss | depth err median | "
       "p99 | max |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const PeerRow& row : r.rows) {
    s << "| " << row.variant << " | " << row.fold << " | ";
    if (row.exact && row.mismatched_pixels != 0) {
      s << "NOT EXACT: " << row.mismatched_pixels << " pixels differ from the CPU reference | | | | | | | |\n";
      continue;
    }
    s << fmt("%.1f", row.ms) << " | " << fmt("%.1f", row.rays / (row.ms * 1e3)) << " | " << fmt("%.1f", mpixels(row))
      << " | " << fmt("%.4f%%", 100 * row.accuracy.disagree()) << " | " << fmt("%.4f%%", 100 * row.accuracy.hit_miss)
      << " | " << fmt("%.1e", row.accuracy.depth_median) << " | " << fmt("%.1e", row.accuracy.depth_p99) << " | "
      << fmt("%.1e", row.accuracy.depth_max) << " |\n";
  }
  const PeerRatios q = peer_ratios(r);
  if (r.valid() && q.fastest_rayfold && q.fastest_embree) {
    s << "\nFastest exact rayfold: " << q.fastest_rayfold->variant << " " << q.fastest_rayfold->fold << ", "
      << fmt("%.1f", mpixels(*q.fastest_rayfold)) << " Mpixels/s. Against Embree's fastest ("
      << q.fastest_embree->variant << ", " << fmt("%.1f", mpixels(*q.fastest_embree)) << "): **"
      << fmt("%.2fx", q.vs_embree) << "**";
    if (q.fastest_embree_instanced)
      s << "; against Embree's fastest instanced (" << q.fastest_embree_instanced->variant << ", "
        << fmt("%.1f", mpixels(*q.fastest_embree_instanced)) << "): **" << fmt("%.2fx", q.vs_embree_instanced) << "**";
    s << ".\n";
  }
  if (!r.valid()) s << "\n**An exact variant differs from the CPU reference: no figure above is valid.**\n";
  return s.str();
}

std::string peers_json(const PeerReport& r) {
  nlohmann::json j;
  j["scene"] = r.scene;
  j["device"] = r.device;
  j["embree_note"] = r.embree_note;
  j["width"] = r.width;
  j["height"] = r.height;
  j["views"] = r.views;
  j["frames"] = r.frames;
  j["threads"] = r.threads;
  j["triangles"] = r.triangles;
  j["instances"] = r.instances;
  j["views_note"] = r.views_note;
  for (const CameraSpec& c : r.cameras)
    j["cameras"].push_back({{"eye", {c.eye.x, c.eye.y, c.eye.z}},
                            {"look_at", {c.look_at.x, c.look_at.y, c.look_at.z}},
                            {"up", {c.up.x, c.up.y, c.up.z}},
                            {"vfov", c.vfov_degrees}});
  j["rayfold_build_ms"] = r.rayfold_build_ms;
  j["build_rounds"] = r.build_rounds;
  j["embree_build_ms"] = r.embree_build_ms;
  auto first = [](const FirstGbuffer& f) {
    return nlohmann::json{{"load_ms", f.load_ms},
                          {"build_ms", f.build_ms},
                          {"frame_ms", f.frame_ms},
                          {"total_ms", f.total()},
                          {"kernels_cached", f.kernels_cached}};
  };
  j["machine"] = {{"cpu", r.machine.cpu_model},
                  {"isa", r.machine.isa},
                  {"opencl_device", r.device},
                  {"tile_lanes", r.tile_lanes},
                  {"embree_isa", r.embree_isa}};
  j["rayfold_first_gbuffer"] = first(r.rayfold_first_gbuffer);
  j["embree_first_gbuffer"] = first(r.embree_first_gbuffer);
  j["embree_high_build_ms"] = r.embree_high_build_ms;
  j["rayfold_build_bytes_per_triangle"] = r.rayfold_build_bytes;
  j["embree_build_bytes_per_triangle"] = r.embree_build_bytes;
  j["embree_high_build_bytes_per_triangle"] = r.embree_high_build_bytes;
  for (const PeerRow& row : r.rows)
    j["rows"].push_back({{"variant", row.variant},
                         {"fold", row.fold},
                         {"ms", row.ms},
                         {"mrays_per_s", row.rays / (row.ms * 1e3)},
                         {"mpixels_per_s", row.pixels / (row.ms * 1e3)},
                         {"disagreeing_share", row.accuracy.disagree()},
                         {"hit_miss_share", row.accuracy.hit_miss},
                         {"depth_error_median", row.accuracy.depth_median},
                         {"depth_error_p99", row.accuracy.depth_p99},
                         {"depth_error_max", row.accuracy.depth_max},
                         {"exact", row.exact},
                         {"measurement_only", row.measurement_only},
                         {"mismatched_pixels", row.mismatched_pixels}});
  const PeerRatios q = peer_ratios(r);
  j["valid"] = r.valid();
  j["ratio_vs_embree_fastest"] = q.vs_embree;
  j["ratio_vs_embree_instanced_fastest"] = q.vs_embree_instanced;
  return j.dump(2) + "\n";
}

}  // namespace rayfold::core
