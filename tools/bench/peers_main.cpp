// rayfold-peers: speed against accuracy for every variant and Embree, in one
// run (tools/bench/peers.h). `make bench` runs it on every scene and charts it.
#include <cstdio>

#include <nlohmann/json.hpp>

#include "cli/cli_args.h"
#include "bench/peers.h"
#include "bench/ray_peers.h"
#include "util/atomic_file.h"
#include "util/errors.h"

#ifndef RAYFOLD_DEFAULT_SCENE
#define RAYFOLD_DEFAULT_SCENE "scenes/atrium.glb"
#endif

int main(int argc, char** argv) {
  using namespace rayfold;
  using namespace rayfold::core;
  return cli::guarded_main([&] {
    PeerOptions opt;
    opt.scene = RAYFOLD_DEFAULT_SCENE;
    std::string json, md;
    bool have_scene = false;
    size_t rays = 0;
    cli::Args args(argc, argv, 1);
    while (!args.done()) {
      const std::string a = args.next();
      if (a == "--help" || a == "-h") {
        std::puts(
            "usage: rayfold-peers [SCENE] [--size WxH] [--views K] [--frames N] [--warmup N] [--threads N]\n"
            "                     [--eye X,Y,Z --look-at X,Y,Z | --random-views K [--seed S]\n"
            "                     [--view-kind auto|interior|object]]\n"
            "                     [--variants tile,tile8,tile16,tile-ab,single,fast,exact-depth,cpu]\n"
            "                     [--ab-defines OPTIONS]\n"
            "                     [--device NAME] [--rays N] [--build-rounds N] [--no-merge] [--json F] [--md F]\n"
            "Speed against accuracy: rayfold's OpenCL tile and single-ray kernels, the fast build, the\n"
            "tile kernel with the exact depth and the CPU reference in every fold mode, and Embree's rtcIntersect1 and "
            "rtcIntersect16 over an\n"
            "instanced and a flat scene (when installed), on the same views, each measured against a\n"
            "double-precision reference. Exact variants are checked bit for bit against the CPU reference\n"
            "first (exit code 3 when one differs). --rays N adds ray queries (Renderer::intersect) against\n"
            "Embree's rtcIntersect1 and rtcIntersect16 on the same rays: N incoherent rays and every view's\n"
            "pixel rays as an array, checked bit for bit against the CPU reference too. --build-rounds N\n"
            "(default 5): bottom-level builds, rayfold's and Embree's alternated, medians reported.\n"
            "tile8 and tile16 force the tile kernel's lanes per vector; tile-ab builds it with\n"
            "--ab-defines' options as well (for example -DRF_KEEP_EACH_GROUP=8), to time a kernel\n"
            "change against the tree's in one process.");
        return 0;
      } else if (parse_view_path_option(a, args, opt, &have_scene)) {
      } else if (a == "--threads") {
        opt.threads = static_cast<unsigned>(cli::parse_int(a, args.value(a), 1, 1024));
      } else if (a == "--build-rounds") {
        opt.build_rounds = cli::parse_int(a, args.value(a), 1, 1000);
      } else if (a == "--no-merge") {
        opt.merge = false;
      } else if (a == "--variants") {
        opt.variants.clear();
        for (const std::string& v : cli::split_list(a, args.value(a))) {
          if (v != "tile" && v != "tile8" && v != "tile16" && v != "tile-ab" && v != "single" && v != "fast" &&
              v != "exact-depth" && v != "cpu")
            throw UsageError(
                "--variants: expected a list of tile, tile8, tile16, tile-ab, single, fast, exact-depth, cpu; got '" +
                v + "'");
          opt.variants.insert(v);
        }
      } else if (a == "--ab-defines") {
        opt.ab_defines = args.value(a);
      } else if (a == "--device") {
        opt.device_hint = args.value(a);
      } else if (a == "--rays") {
        rays = static_cast<size_t>(cli::parse_int(a, args.value(a), 0, 100000000));
      } else if (a == "--json") {
        json = args.value(a);
      } else if (a == "--md") {
        md = args.value(a);
      } else {
        throw UsageError("unknown option '" + a + "' (see rayfold-peers --help)");
      }
    }
    check_view_path(opt);
    if (opt.variants.count("tile-ab") != (opt.ab_defines.empty() ? 0u : 1u))
      throw UsageError("--ab-defines and the variant tile-ab go together: each needs the other");
    for (const std::string* out : {&json, &md})
      if (!out->empty()) check_writable(*out);
    const PeerReport report = run_peers(opt);
    std::string text = peers_markdown(report);
    std::fputs(text.c_str(), stdout);
    std::string report_json = peers_json(report);
    bool valid = report.valid();
    if (rays > 0) {
      const RayPeerReport queries = run_ray_peers(opt, rays);
      const std::string more = ray_peers_markdown(queries);
      std::fputs(more.c_str(), stdout);
      text += more;
      nlohmann::json j = nlohmann::json::parse(report_json);
      j["ray_queries"] = nlohmann::json::parse(ray_peers_json(queries));
      report_json = j.dump(1);
      valid = valid && queries.valid();
    }
    if (!json.empty()) write_text_file(json, report_json);
    if (!md.empty()) write_text_file(md, text);
    if (!valid) {
      std::fprintf(stderr, "error: an exact variant differs from the CPU reference; the figures are not valid\n");
      return 3;
    }
    return 0;
  });
}
