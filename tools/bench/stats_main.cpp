// rayfold-stats: traversal counts of both kernels, to see where a scene's
// trace time goes. A diagnostic, not a benchmark.
//  - single-ray (the CPU reference's traversal): per ray, top-level nodes,
//    instances entered, set-ups, bottom-level nodes, triangle tests;
//  - tile (on the OpenCL device, built with its counters): per tile and per
//    answered pixel, nodes, lane-group box and triangle tests, set-ups.
#define RF_TRAVERSAL_STATS 1
#include <cstdio>

#include <algorithm>
#include <cmath>

#include "cli/cli_args.h"
#include "fold/frame.h"
#include "fold/ray_list.h"
#include "opencl/cl_tracer.h"
#include "reference/double_reference.h"
#include "rf_trace.h"
#include "scene/camera.h"
#include "scene/gltf_loader.h"
#include "util/errors.h"
#include "util/span.h"

thread_local rf_traversal_stats rf_stats;

namespace rayfold::core {
namespace {

// Where the depth error against the double reference comes from, pixel by
// pixel on same-triangle hits: the float ray itself (the exact depth of the
// float object-space ray rayfold traces, on the reported triangle, against
// the exact ray's), and the triangle test (rayfold's depth against that
// float ray's exact depth: the watertight t and the raise to the leaf entry).
void print_depth_sources(const Scene& scene, const SceneData& data, const Camera& cam, const Frame& frame,
                         ConstSpan<rf_pixel_hit> hits) {
  const std::vector<ReferenceHit> ref = trace_double_reference(scene, data, cam, 0);
  std::vector<const rf_instance*> copy(scene.instances.size(), nullptr);
  for (const rf_instance& inst : frame.instances)
    if (inst.group == 0 && !copy[inst.instance_id]) copy[inst.instance_id] = &inst;
  std::vector<double> ray_err, test_err, total;
  const double scale = frame.views[0].depth_scale;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const size_t i = static_cast<size_t>(y) * cam.width + x;
      const rf_pixel_hit& h = hits[i];
      if (h.instance == RF_INVALID || h.instance != ref[i].instance || h.primitive != ref[i].primitive) continue;
      const rf_instance* inst = copy[h.instance];
      if (!inst) continue;
      const uint32_t mesh = scene.instances[h.instance].mesh;
      const Mesh& m = scene.meshes[mesh];
      const double to_tree = std::ldexp(1.0, -data.blas.tree_exponents[mesh]);
      glm::dvec3 v[3];
      for (int k = 0; k < 3; ++k) v[k] = glm::dvec3(m.positions[m.indices[3 * h.primitive + k]]) * to_tree;
      const float dx = cam.params.scale_x * (static_cast<float>(2 * x + cam.params.kx0) + cam.params.frac_x);
      const float dy = cam.params.scale_y * (static_cast<float>(cam.params.ky0 - 2 * y) + cam.params.frac_y);
      rf_ray r;
      rf_ray_to_object(&r, inst->tree_from_trace, dx, dy, -1.0f);
      const glm::dvec3 o(r.o[0], r.o[1], r.o[2]), d(r.d[0], r.d[1], r.d[2]);
      const glm::dvec3 n = glm::cross(v[1] - v[0], v[2] - v[0]);
      const double t = glm::dot(v[0] - o, n) / glm::dot(d, n);
      const double len = std::sqrt(static_cast<double>(dx) * dx + static_cast<double>(dy) * dy + 1.0);
      const double z_float_ray = t * len * scale;
      ray_err.push_back(std::fabs(z_float_ray - ref[i].distance) / ref[i].distance);
      test_err.push_back(std::fabs(h.z - z_float_ray) / z_float_ray);
      total.push_back(std::fabs(h.z - ref[i].distance) / ref[i].distance);
    }
  auto report = [](const char* what, std::vector<double> e) {
    if (e.empty()) return;
    std::sort(e.begin(), e.end());
    std::printf("  depth error from %-14s median %.1e  p99 %.1e  p99.9 %.1e  max %.1e\n", what, e[e.size() / 2],
                e[std::min(e.size() - 1, static_cast<size_t>(0.99 * e.size()))],
                e[std::min(e.size() - 1, static_cast<size_t>(0.999 * e.size()))], e.back());
  };
  std::printf("  depth error sources over %zu same-triangle pixels (relative):\n", total.size());
  report("the float ray:", ray_err);
  report("the test:", test_err);
  report("both:", total);
}

}  // namespace
}  // namespace rayfold::core

int main(int argc, char** argv) {
  using namespace rayfold;
  using namespace rayfold::core;
  return cli::guarded_main([&] {
    const char* usage =
        "usage: rayfold-stats SCENE [--eye X,Y,Z --look-at X,Y,Z [--up X,Y,Z]] [--size WxH] [--fold MODE] [--no-braid]\n"
        "                     [--no-merge]\n"
        "                     [--braid-items N] [--braid-min N] [--braid-loose R] [--vfov DEG] [--depth-sources]\n"
        "Traversal counters per ray and per pixel: the single-ray kernel's on the CPU reference, the tile\n"
        "kernel's on the OpenCL device (default 320x180, the file's camera or a framing view).\n"
        "--depth-sources: also split the depth error against the double reference into the float ray's\n"
        "and the triangle test's.";
    if (argc >= 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h")) {
      std::puts(usage);
      return 0;
    }
    if (argc < 2) throw UsageError(std::string("no scene given\n") + usage);
    cli::Args args(argc, argv, 2);
    const Scene scene = load_gltf(argv[1]);
    CameraSpec spec = scene.camera ? *scene.camera : frame_bounds(scene.world_bounds());
    int w = 320, h = 180;
    Fold fold = Fold::none;
    BraidOptions braid;
    MergeOptions merge;
    bool depth_sources = false;
    while (!args.done()) {
      const std::string a = args.next();
      if (a == "--eye")
        spec.eye = cli::parse_vec3(a, args.value(a));
      else if (a == "--look-at")
        spec.look_at = cli::parse_vec3(a, args.value(a));
      else if (a == "--up")
        spec.up = cli::parse_vec3(a, args.value(a));
      else if (a == "--depth-sources")
        depth_sources = true;
      else if (a == "--vfov")
        spec.vfov_degrees = cli::parse_double(a, args.value(a));
      else if (a == "--size")
        cli::parse_size(a, args.value(a), &w, &h);
      else if (a == "--fold")
        fold = cli::parse_fold(a, args.value(a));
      else if (a == "--no-braid")
        braid.enabled = false;
      else if (a == "--no-merge")
        merge.enabled = false;
      else if (a == "--braid-items")
        braid.items_per_instance = cli::parse_int(a, args.value(a), 1, 1 << 20);
      else if (a == "--braid-loose")
        braid.loose_ratio = cli::parse_double(a, args.value(a));
      else if (a == "--braid-min")
        braid.min_items = cli::parse_int(a, args.value(a), 0, 1 << 24);
      else
        throw UsageError("unknown option " + a);
    }
    const Camera cam = make_camera(spec, w, h);
    const SceneData data = prepare_scene(scene, 0, braid, merge);
    const RayList rays = make_ray_list(cam.params, fold);
    FrameOptions options;
    options.fold = fold;
    const Frame frame = build_frame(scene, data, cam, rays, options);
    const rf_camera traced = frame_camera(cam, frame);
    std::vector<rf_node> nodes(data.blas.nodes.begin(), data.blas.nodes.end());
    nodes.insert(nodes.end(), frame.tlas_nodes.begin(), frame.tlas_nodes.end());
    std::vector<rf_pixel_hit> out(static_cast<size_t>(w) * h);
    const std::vector<float> depth_scales = frame.depth_scales();
    const rf_depth_table depths{frame.depth_xforms.data(), frame.depth_instances};
    const rf_answers answers = rf_answers_in(out.data());
    const rf_alpha_tables alpha = data.alpha.view();
    for (uint32_t e : rays.entries)
      rf_trace_entry(e, &traced, depth_scales.data(), &depths, nodes.data(), data.blas.tris.data(),
                     frame.instances.data(), data.normal_xforms.data(), frame.tlas_root, &answers,
                     data.alpha.empty() ? nullptr : &alpha);
    const double n = static_cast<double>(rays.entries.size());
    const double px = static_cast<double>(rays.pixels);
    std::printf("%s (fold %s, %zu rays for %zu pixels; BLAS SAH %.1f, TLAS SAH %.1f, %zu instances kept)\n", argv[1],
                fold_name(fold), rays.entries.size(), rays.pixels, data.blas.sah_cost, frame.stats.tlas_sah,
                frame.stats.kept);
    std::printf(
        "  single-ray, per ray:   %.1f TLAS nodes, %.2f instances (%.2f set-ups), %.1f BLAS nodes, %.1f "
        "triangle tests\n",
        rf_stats.tlas_nodes / n, rf_stats.instances / n, rf_stats.setups / n, rf_stats.blas_nodes / n,
        rf_stats.triangles / n);
    std::printf("  single-ray, per pixel: %.1f TLAS nodes, %.2f set-ups, %.1f BLAS nodes, %.1f triangle tests\n",
                rf_stats.tlas_nodes / px, rf_stats.setups / px, rf_stats.blas_nodes / px, rf_stats.triangles / px);

    if (depth_sources && fold == Fold::none) print_depth_sources(scene, data, cam, frame, out);

    // The tile kernel on the OpenCL device, with its counters.
    ClDevice device;
    ClTracer tracer(device, KernelPrecision::exact, true);
    tracer.upload_scene(data, frame.tlas_nodes.size(), frame.instances.size(), rays.entries.size(), out.size());
    tracer.upload_frame(frame);
    tracer.upload_rays(rays);
    tracer.trace(traced, KernelKind::tile);
    const std::vector<uint32_t> st = tracer.read_tile_stats();
    double sum[RF_TILE_STAT_COUNT] = {};
    for (size_t i = 0; i < st.size(); ++i) sum[i % RF_TILE_STAT_COUNT] += st[i];
    const double tiles = static_cast<double>(rays.tiles.size() - 1);
    std::printf(
        "  tile (%u lanes), per tile of %.0f rays: %.1f TLAS nodes (%.1f lane-group boxes), %.1f instances "
        "(%.1f set-ups), %.1f BLAS nodes (%.1f lane-group boxes), %.1f leaves, %.1f lane-group triangle "
        "tests\n",
        tile_lanes(device.info()), n / tiles, sum[RF_TILE_STAT_TLAS_NODES] / tiles,
        sum[RF_TILE_STAT_TLAS_LANE_BOXES] / tiles, sum[RF_TILE_STAT_INSTANCES] / tiles,
        sum[RF_TILE_STAT_SETUPS] / tiles, sum[RF_TILE_STAT_BLAS_NODES] / tiles,
        sum[RF_TILE_STAT_BLAS_LANE_BOXES] / tiles, sum[RF_TILE_STAT_LEAVES] / tiles,
        sum[RF_TILE_STAT_TRI_LANES] / tiles);
    const double lanes = tile_lanes(device.info());
    std::printf(
        "  tile, per pixel (lane tests count each lane): %.1f TLAS box lanes, %.2f set-up lanes, %.1f BLAS "
        "box lanes, %.1f triangle lanes\n",
        sum[RF_TILE_STAT_TLAS_LANE_BOXES] * lanes / px, sum[RF_TILE_STAT_SETUPS] * RF_TILE_RAYS / px,
        sum[RF_TILE_STAT_BLAS_LANE_BOXES] * lanes / px, sum[RF_TILE_STAT_TRI_LANES] * lanes / px);
    return 0;
  });
}
