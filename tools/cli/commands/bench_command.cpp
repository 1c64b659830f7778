// `rayfold bench`: every fold mode (or alignment) on the same camera path.
#include <cstdio>
#include <vector>

#include "api/pipeline_options.h"
#include "bench/bench.h"
#include "bench/bench_align.h"
#include "cli/commands/common.h"
#include "cli/progress.h"
#include "util/atomic_file.h"
#include "util/errors.h"

namespace rayfold::core::commands {
namespace {

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
    "  --random-views K       instead of the path, K views nobody chose (tools/fixtures/random_views.h)\n"
    "  --seed S               the random views' seed (default 1)\n"
    "  --view-kind auto|interior|object   how they are drawn (default auto: by a probe)\n"
    "  --animate              move a fixed subset of instances every frame\n"
    "  --braid N              re-braiding budget per instance (default 2, 0 = off)\n"
    "  --no-merge             a tree per mesh, also for instances that share a transform\n"
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

}  // namespace

int run_bench_command(cli::Args& args) {
  BenchOptions opt;
  opt.scene = default_scene();
  std::string json, md;
  bool have_scene = false, align = false;
  double baseline = 0.0;
  std::vector<int> counts{2, 4, 8, 16};
  rayfold::RendererOptions renderer;  // as rayfold render takes it, then the pipeline's
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
    } else if (parse_renderer_option(a, args, renderer)) {
    } else if (a == "--json") {
      json = args.value(a);
    } else if (a == "--md") {
      md = args.value(a);
    } else {
      throw UsageError("bench: unknown option '" + a + "' (see rayfold bench --help)");
    }
  }
  check_view_path(opt);
  check_renderer_options(renderer);
  if (!renderer.cull)
    throw UsageError("--no-cull: bench measures the unfolded baseline with and without culling already");
  opt.renderer = rayfold::detail::pipeline_options(renderer);
  check_outputs({{"--json", &json, ".json"}, {"--md", &md, ".md"}});
  for (const std::string* out : {&json, &md})
    if (!out->empty()) prepare_output(*out);
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

}  // namespace rayfold::core::commands
