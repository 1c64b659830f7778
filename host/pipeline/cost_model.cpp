// Pipeline::predict: the cost model of docs/cost_model.md. A trace of n
// tiles takes T = o + n * c: o the launch (and finish) overhead, measured
// on a one-ray trace, c the mean cost of a tile under the choice, measured
// on every stride-th tile at full resolution. Tiles are the kernels' unit of
// coherence (the tile kernel's work-item, 4 of the single-ray kernel's
// work-groups), so a sample of whole tiles costs what they cost in the
// render; a lower-resolution image would not.
#include "pipeline/cost_model.h"

#include <algorithm>

#include "pipeline/pipeline.h"
#include "reference/cpu_tracer.h"
#include "util/errors.h"
#include "util/timer.h"

namespace rayfold::core {

std::string choice_name(const Choice& c) {
  return std::string(fold_name(c.fold)) + "/" + kernel_name(c.kernel) + "/align " + std::to_string(c.align);
}

std::vector<Prediction> Pipeline::predict(const std::vector<Camera>& views, const std::vector<Choice>& choices,
                                          int stride) {
  RF_CHECK(!views.empty() && stride >= 1, "nothing to predict");
  // Five rounds over every choice, each choice's least time kept: noise on
  // a shared CPU only ever adds time, and a slow spell then hits every
  // choice alike instead of the ones probed during it (one choice after the
  // other, medians of three were off by up to 2x on a 2-core machine).
  constexpr int kRounds = 5;
  const Camera& first = views[0];
  const size_t view_pixels = static_cast<size_t>(first.width) * first.height;
  struct Probe {
    Prediction p;
    std::vector<Camera> pass;
    Frame frame;
    RayList sample, one;
    rf_camera cam{};
    KernelKind kernel = KernelKind::tile;
    double scale = 1.0, update_ms = 0.0, best = 1e300, overhead = 1e300;
  };
  std::vector<Probe> probes(choices.size());
  for (size_t i = 0; i < choices.size(); ++i) {
    Probe& pr = probes[i];
    const Choice& c = choices[i];
    const Fold fold = restrict_fold(c.fold, can_fold_columns(first), can_fold_rows(first));
    const int per_pass = std::max(1, std::min({c.align, max_pass_views(fold), static_cast<int>(views.size())}));
    if (per_pass == 1)
      pr.pass.push_back(views[views.size() / 2]);
    else
      pr.pass.assign(views.begin(), views.begin() + per_pass);
    const int groups = pass_groups(per_pass, fold);
    ensure_capacity(view_pixels * pr.pass.size(), groups);
    if (tracer_) tracer_->prepare_groups(groups);
    const RayList& rays = ray_list(first.params, fold);
    pr.sample = sample_tiles(rays, static_cast<size_t>(stride));
    pr.scale = static_cast<double>(rays.tiles.size() - 1) / std::max<size_t>(pr.sample.tiles.size() - 1, 1);
    // One ray in one tile: a trace that is all overhead.
    pr.one.entries.assign(rays.entries.begin(), rays.entries.begin() + std::min<size_t>(rays.entries.size(), 1));
    pr.one.tiles = {0, static_cast<uint32_t>(pr.one.entries.size())};
    FrameOptions fo;
    fo.fold = fold;
    const auto t0 = Clock::now();
    pr.frame = build_frame(scene_, *data_, pr.pass, rays, fo);
    pr.update_ms = ms_since(t0);
    pr.cam = frame_camera(first, pr.frame);
    // Parallel rays always trace with the single-ray kernel (render_views_into).
    pr.kernel = is_orthographic(first) ? KernelKind::single : c.kernel;
    pr.p.choice = c;
    pr.p.choice.fold = fold;
    pr.p.choice.align = per_pass;
  }
  std::vector<rf_pixel_hit> scratch;
  for (int round = 0; round < kRounds; ++round) {
    for (Probe& pr : probes) {
      const auto p0 = Clock::now();
      if (tracer_) {
        const double upload = tracer_->upload_frame(pr.frame);
        if (round == 0) pr.update_ms += upload;
        tracer_->bind_output(nullptr, 0);  // the device's own hit buffer: nothing to keep
        tracer_->upload_rays(pr.one, kProbeSlot);
        pr.overhead = std::min(pr.overhead, tracer_->trace(pr.cam, pr.kernel));
        tracer_->upload_rays(pr.sample, kProbeSlot);
        pr.best = std::min(pr.best, tracer_->trace(pr.cam, pr.kernel));
      } else {
        scratch.resize(view_pixels * pr.pass.size());
        const TraceInputs in = host_inputs(pr.frame);
        const std::vector<float> depth_scales = pr.frame.depth_scales();
        const auto s0 = Clock::now();
        trace_cpu(in, pr.sample, pr.cam, depth_scales.data(), scratch.data(), options_.threads);
        pr.best = std::min(pr.best, ms_since(s0));
        pr.overhead = 0.0;
      }
      pr.p.probe_ms += ms_since(p0);
    }
  }
  std::vector<Prediction> out;
  for (Probe& pr : probes) {
    const double n = static_cast<double>(pr.pass.size());
    const double work = std::max(pr.best - pr.overhead, 0.0) * pr.scale;
    pr.p.trace_ms = (pr.overhead + work) / n;
    pr.p.update_ms = pr.update_ms / n;
    pr.p.probe_ms += pr.update_ms;
    out.push_back(pr.p);
  }
  return out;
}

void Pipeline::set_kernel(KernelKind kernel, const std::string& why) {
  kernel_ = kernel;
  kernel_reason_ = why;
  measure_kernel_ = false;
}

AutoChoice choose_fastest(Pipeline& renderer, const std::vector<Camera>& views, const std::vector<Fold>& folds,
                          const std::vector<KernelKind>& kernels, const std::vector<int>& aligns) {
  RF_CHECK(!folds.empty() && !kernels.empty() && !aligns.empty(), "no choice to make");
  const auto t0 = Clock::now();
  AutoChoice out;
  // The kernels first, at one fold and alignment: they differ by several
  // times where they differ (3 to 8x on a CPU), so a kernel predicted more
  // than twice as slow there is not probed in every combination (its probes
  // are the expensive ones).
  std::vector<KernelKind> kept = kernels;
  if (kernels.size() > 1) {
    std::vector<Choice> first;
    for (KernelKind k : kernels) first.push_back({folds[0], k, aligns.back()});
    const std::vector<Prediction> p = renderer.predict(views, first);
    double fastest = 1e300;
    for (const Prediction& x : p) fastest = std::min(fastest, x.total_ms());
    kept.clear();
    for (const Prediction& x : p) {
      if (x.total_ms() <= 2.0 * fastest)
        kept.push_back(x.choice.kernel);
      else
        out.predictions.push_back(x);
    }
  }
  std::vector<Choice> choices;
  for (Fold f : folds)
    for (KernelKind k : kept)
      for (int a : aligns) choices.push_back({f, k, a});
  const std::vector<Prediction> p = renderer.predict(views, choices);
  out.predictions.insert(out.predictions.end(), p.begin(), p.end());
  out.probe_ms = ms_since(t0);
  std::stable_sort(out.predictions.begin(), out.predictions.end(),
                   [](const Prediction& a, const Prediction& b) { return a.total_ms() < b.total_ms(); });
  out.best = out.predictions.front().choice;
  return out;
}

}  // namespace rayfold::core
