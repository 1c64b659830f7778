// `rayfold bench --align`: views rendered alone against the same views traced
// together (alignment), side by side in one run, per fold and kernel, on a
// stereo pair and on camera paths of N = 2, 4, 8, 16 views. Every aligned
// view is checked bit for bit against the same view alone before a figure is
// reported.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "bench/bench.h"

namespace rayfold::core {

struct AlignBenchOptions : ViewPath {
  PipelineOptions renderer;
  std::vector<int> counts{2, 4, 8, 16};  // path lengths
  std::vector<Fold> folds{Fold::none, Fold::y, Fold::x, Fold::xy};
  // Stereo baseline in world units; 0: 64 mm for a scene 20 m across,
  // scaled to the scene's diagonal (0.0032 of it).
  double baseline = 0.0;
};

// Traversal counters of the tile kernel (kernels/rf_types.h), summed over
// the tiles of one trace.
struct TileCounters {
  double tlas_nodes = 0, instances = 0, setups = 0, blas_nodes = 0, tri_lanes = 0;
};

struct AlignRow {
  std::string scenario;  // "stereo", "path"
  int views = 0;
  Fold fold = Fold::none;
  std::string kernel;                         // "tile", "single", "cpu reference"
  int passes = 0;                             // traces per frame when aligned
  double alone_ms = 0.0;                      // per view: trace + readback, median over frames, mean over views
  double aligned_ms = 0.0;                    // per view: the passes' medians summed, over the views
  double alone_update_ms = 0.0;               // per view: culling + top-level build + upload
  double aligned_update_ms = 0.0;             // per view, likewise
  size_t alone_bytes = 0, aligned_bytes = 0;  // device bytes of one frame: scene, top level, rays, hits
  double alone_instances = 0.0, aligned_instances = 0.0;  // top-level items, per view
  TileCounters alone_counts, aligned_counts;              // per view (tile kernel only)
  size_t mismatched_pixels = 0;                           // aligned against alone, over every view
  // The cost model's prediction (Pipeline::predict) of trace + update per
  // view, made before measuring, against the measured trace + update.
  double alone_predicted_ms = 0.0, aligned_predicted_ms = 0.0;
  double alone_measured_ms = 0.0, aligned_measured_ms = 0.0;
  double speedup() const { return aligned_ms > 0.0 ? alone_ms / aligned_ms : 0.0; }
};

// Per scenario: what `auto` (the choice of least predicted time) picked,
// and how its measured time compares with the best measured choice.
struct AutoCheck {
  std::string scenario;
  int views = 0;
  std::string picked, best;
  double picked_ms = 0.0, best_ms = 0.0;  // measured trace + update per view
  double probe_ms = 0.0;                  // the prediction's own cost, all choices
};

struct AlignReport {
  std::string scene, device;
  int width = 0, height = 0, frames = 0, warmup = 0;
  unsigned threads = 0;
  double baseline = 0.0;
  size_t instances = 0, triangles = 0;
  std::vector<AlignRow> rows;
  std::vector<AutoCheck> autos;
  bool exact() const;
};

AlignReport run_align_bench(const AlignBenchOptions& options,
                            const std::function<void(size_t done, size_t total)>& progress = {});
std::string align_markdown(const AlignReport& report);
std::string align_json(const AlignReport& report);

}  // namespace rayfold::core
