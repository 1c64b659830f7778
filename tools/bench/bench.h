// `rayfold bench`: every fold mode on the same camera path, side by side in
// one run, with the paper's Table 1 (render time, memory) and Table 2
// (pre-build, per-frame update). Every folded image is checked bit for bit
// against the unfolded one before a figure is reported.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "cli/cli_args.h"
#include "bench/machine_info.h"
#include "fixtures/random_views.h"
#include "pipeline/pipeline.h"

namespace rayfold::core {

// What the benchmarks render: a scene, an image size, and K views, each
// measured over some frames after a warm-up: on a short path around a base
// view, or (random) drawn by random_views.h from a seed.
struct ViewPath {
  std::string scene;
  int width = 1280, height = 720;
  int views = 8;                           // cameras on the path, or random views
  int frames = 5;                          // measured frames per view and method
  int warmup = 1;                          // frames per view and method before measuring
  std::optional<glm::dvec3> eye, look_at;  // base view; default the file's camera
  bool random = false;                     // --random-views N: views nobody chose
  uint64_t seed = 1;                       // --seed
  bool seed_given = false;
  ViewKind kind = ViewKind::automatic;     // --view-kind
  // What the random views were drawn as, in words, after camera_path (empty
  // for a path): for the reports.
  mutable std::string views_note;
};

struct BenchOptions : ViewPath {
  bool animate = false;
  PipelineOptions renderer;
};

struct BenchRow {
  std::string method;  // "none (no culling)", "none", "y", "x", "xy"
  Fold fold = Fold::none;
  bool cull = true;
  double render_ms = 0.0;  // T: ray list + trace + readback, mean over views of per-view medians
  double trace_ms = 0.0;
  double update_ms = 0.0;        // culling + TLAS build + upload
  size_t memory_bytes = 0;       // M: the largest over views of the bytes the frame uses on the device
  double rays = 0.0;             // traced per frame, mean over views
  double instances = 0.0;        // in the TLAS, mean over views
  size_t mismatched_pixels = 0;  // against the unfolded image, over all views
};

struct BenchReport {
  std::string scene, device, kernel;  // kernel: which one traced (Pipeline::kernel_label)
  MachineInfo machine;                // the CPU the figures are from
  unsigned tile_lanes = 0;            // the tile kernel's rays per vector (0: the CPU backend)
  std::string views_note;             // ViewPath::views_note: which random views, if any
  int width = 0, height = 0, views = 0, frames = 0, warmup = 0;
  unsigned threads = 0;
  size_t instances = 0, meshes = 0, triangles = 0;
  double prebuild_ms = 0.0;  // all BLAS builds
  bool animate = false;
  std::vector<BenchRow> rows;
  bool exact() const;
};

// printf of one number, for report tables.
std::string fmt(const char* format, double value);
// Bytes a frame uses on the device: the scene (BLAS nodes, triangles, normal
// matrices), the frame (TLAS nodes, instances), the ray list and `pixels`
// hits (every view's).
size_t frame_bytes(const SceneData& data, const RenderResult& r, size_t pixels);

// Parses one ViewPath option (--size --views --frames --warmup --eye
// --look-at --random-views --seed --view-kind) or a positional scene; false
// when `a` is none of them.
bool parse_view_path_option(const std::string& a, cli::Args& args, ViewPath& path, bool* have_scene);
// After parsing: --eye and --look-at go together, and neither goes with
// --random-views.
void check_view_path(const ViewPath& path);

// `progress` (may be null) is told each frame done, of views x methods x
// (warm-up + frames).
BenchReport run_bench(const BenchOptions& options, const std::function<void(size_t done, size_t total)>& progress = {});
std::string bench_markdown(const BenchReport& report);
std::string bench_json(const BenchReport& report);

// The K cameras of the benchmark path around a base view: the eye swings
// +-20 degrees about the vertical axis through the look-at point and dollies
// in and out by 10%.
std::vector<CameraSpec> camera_path(const CameraSpec& base, int views);

// The path's cameras for a loaded scene: around the given base view, else the
// file's camera, else a view framing the scene; or the random views (drawn
// with a CPU-reference renderer of the scene, which sets path.views_note).
std::vector<CameraSpec> camera_path(const Scene& scene, const ViewPath& path);

}  // namespace rayfold::core
