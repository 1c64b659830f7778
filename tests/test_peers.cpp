// The speed/accuracy benchmark's rows are real: Embree (when built in) finds
// nearly the double reference's triangles with the very same rays, and the
// fold modes of each rayfold variant report the same accuracy.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/embree_peer.h"
#include "bench/peak_memory.h"
#include "bench/peers.h"
#include "bench/ray_peers.h"
#include "reference/cpu_tracer.h"
#include "pipeline/pipeline.h"
#include "scene/gltf_loader.h"
#include "test_util.h"
#include "util/errors.h"

namespace rayfold::core {
namespace {

// The bundled scene, small, two views of one frame each.
PeerOptions small_run(int width, int height) {
  PeerOptions opt;
  opt.scene = std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb";
  opt.width = width;
  opt.height = height;
  opt.views = 2;
  opt.frames = 1;
  opt.warmup = 0;
  return opt;
}

TEST(Peers, EveryVariantIsMeasured) {
  const PeerOptions opt = small_run(96, 54);
  const PeerReport r = run_peers(opt);
  // Five rayfold variants in four fold modes, then Embree instanced, flat and
  // flat at high build quality, single rays and packets; on an AVX-512 CPU
  // Embree's flat scene forced to AVX2 too.
  const size_t avx2_rows = r.embree_isa == "AVX-512" ? 2u : 0u;
  ASSERT_EQ(r.rows.size(), EmbreePeer::available() ? 26u + avx2_rows : 20u);
  if (!EmbreePeer::available()) {
    EXPECT_FALSE(r.embree_note.empty());
  }
  for (const PeerRow& row : r.rows) {
    EXPECT_GT(row.ms, 0.0) << row.variant << " " << row.fold;
    EXPECT_GT(row.accuracy.same_hit, 0.99) << row.variant << " " << row.fold;
    EXPECT_LT(row.accuracy.depth_median, 1e-5) << row.variant << " " << row.fold;
  }
  // The exact variants (tile, single, CPU reference) give identical bits in
  // every fold mode, checked pixel by pixel: identical accuracy.
  EXPECT_TRUE(r.valid());
  for (const PeerRow& row : r.rows) {
    if (!row.exact) continue;
    EXPECT_EQ(row.mismatched_pixels, 0u) << row.variant << " " << row.fold;
    EXPECT_EQ(row.accuracy.same_hit, r.rows[0].accuracy.same_hit) << row.variant << " " << row.fold;
  }
  EXPECT_EQ(r.rows[0].variant, "OpenCL tile");
  EXPECT_TRUE(r.rows[0].exact);
  EXPECT_FALSE(r.rows[8].exact) << r.rows[8].variant;  // the fast build promises no bits
  // The exact depth: validated against the CPU reference's exact depth, and
  // within one rounding of the double reference where the tile's is not.
  for (int k = 12; k < 16; ++k) {
    EXPECT_EQ(r.rows[k].variant, "OpenCL tile exact depth");
    EXPECT_TRUE(r.rows[k].exact);
    EXPECT_LE(r.rows[k].accuracy.depth_max, 0x1p-23) << r.rows[k].fold;
    EXPECT_LT(r.rows[k].accuracy.depth_max, r.rows[0].accuracy.depth_max) << r.rows[k].fold;
  }
  const std::string md = peers_markdown(r);
  EXPECT_EQ(r.build_rounds, opt.build_rounds);
  EXPECT_NE(md.find("Bottom-level build (median of " + std::to_string(opt.build_rounds) + ","), std::string::npos) << md;
  EXPECT_NE(md.find("| OpenCL tile | xy |"), std::string::npos);
  EXPECT_NE(md.find("| OpenCL single | xy |"), std::string::npos);
  if (EmbreePeer::available()) {
    EXPECT_NE(md.find("| Embree flat rtcIntersect16 |"), std::string::npos);
    EXPECT_NE(md.find("| Embree flat high rtcIntersect16 |"), std::string::npos);
    EXPECT_GT(r.embree_build_ms, 0.0);
    EXPECT_GT(r.embree_high_build_ms, 0.0);
    if (PeakMemory().available()) {
      // Per scene triangle: the atrium's meshes are instanced, so rayfold
      // builds a fifth of them, Embree's flat scene all.
      EXPECT_GT(r.rayfold_build_bytes, 5.0);
      EXPECT_GT(r.embree_build_bytes, 20.0);
      EXPECT_NE(md.find("B/scene triangle"), std::string::npos);
    }
    const PeerRatios q = peer_ratios(r);
    ASSERT_NE(q.fastest_rayfold, nullptr);
    EXPECT_TRUE(q.fastest_rayfold->exact);
    EXPECT_GT(q.vs_embree, 0.0);
    EXPECT_NE(md.find("Fastest exact rayfold"), std::string::npos);
  }
}

// The peak counts what a step touched, freed or not, and nothing before it.
TEST(Peers, PeakMemorySeesWhatAStepTouched) {
  if (!PeakMemory().available()) GTEST_SKIP() << "no /proc/self/clear_refs here: peak memory is not reported";
  const PeakMemory idle;
  EXPECT_LT(idle.peak_bytes(), size_t{8} << 20);
  const PeakMemory step;
  {
    std::vector<char> block(size_t{64} << 20);
    std::memset(block.data(), 1, block.size());
  }
  EXPECT_GE(step.peak_bytes(), size_t{60} << 20);
  const PeakMemory after;
  EXPECT_LT(after.peak_bytes(), size_t{8} << 20);  // the block went back to the system
}

// --variants tile: the tile kernel's rows alone are timed, still validated
// against the CPU reference, which is not timed; random views are named and
// listed as the camera list they are.
TEST(Peers, ChosenVariantsOnRandomViews) {
  PeerOptions opt = small_run(64, 36);
  opt.random = true;
  opt.seed = 3;
  opt.variants = {"tile"};
  const PeerReport r = run_peers(opt);
  ASSERT_EQ(r.rows.size(), EmbreePeer::available() ? 10u + (r.embree_isa == "AVX-512" ? 2u : 0u) : 4u);
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(r.rows[i].variant, "OpenCL tile");
    EXPECT_TRUE(r.rows[i].exact);
    EXPECT_EQ(r.rows[i].mismatched_pixels, 0u);
  }
  EXPECT_TRUE(r.valid());
  EXPECT_NE(r.views_note.find("2 random interior views, seed 3"), std::string::npos) << r.views_note;
  EXPECT_NE(peers_markdown(r).find("Views: 2 random"), std::string::npos);
  ASSERT_EQ(r.cameras.size(), 2u);
  EXPECT_GT(r.rayfold_build_ms, 0.0);
}

// The report names its machine: the CPU and its ISA as /proc/cpuinfo says,
// the OpenCL device with the tile kernel's lanes, Embree's ISA; and on an
// AVX-512 CPU, Embree forced to AVX2 answers as the flat scene does.
TEST(Peers, TheReportNamesItsMachine) {
  PeerOptions opt = small_run(64, 36);
  opt.variants = {"tile"};
  const PeerReport r = run_peers(opt);
  const MachineInfo host = read_machine_info();
  EXPECT_EQ(r.machine.cpu_model, host.cpu_model);
  EXPECT_EQ(r.machine.isa, host.isa);
  EXPECT_TRUE(r.tile_lanes == 8 || r.tile_lanes == 16) << r.tile_lanes;
  const std::string md = peers_markdown(r);
  EXPECT_NE(md.find("Machine: " + machine_label(host) + "; rayfold device: " + r.device + ", tile kernel " +
                    std::to_string(r.tile_lanes) + " lanes"),
            std::string::npos)
      << md;
  const nlohmann::json j = nlohmann::json::parse(peers_json(r));
  EXPECT_EQ(j["machine"]["cpu"], host.cpu_model);
  EXPECT_EQ(j["machine"]["tile_lanes"], r.tile_lanes);
  if (!EmbreePeer::available()) return;
  // Embree never traces wider than the host allows.
  if (host.isa != "AVX-512") {
    EXPECT_NE(r.embree_isa, "AVX-512");
  }
  EXPECT_NE(md.find("; Embree " + r.embree_isa + "."), std::string::npos) << md;
  if (r.embree_isa != "AVX-512") {
    EXPECT_TRUE(r.embree_avx2_note.empty());
    return;
  }
  EXPECT_NE(r.embree_avx2_note.find("it traces with AVX2"), std::string::npos) << r.embree_avx2_note;
  const PeerRow *flat16 = nullptr, *avx2_16 = nullptr;
  for (const PeerRow& row : r.rows) {
    if (row.variant == "Embree flat rtcIntersect16") flat16 = &row;
    if (row.variant == "Embree flat AVX2 rtcIntersect16") avx2_16 = &row;
  }
  ASSERT_NE(flat16, nullptr);
  ASSERT_NE(avx2_16, nullptr);
  EXPECT_TRUE(avx2_16->measurement_only);
  EXPECT_FALSE(peer_ratios(r).fastest_embree->measurement_only);
  EXPECT_GT(avx2_16->ms, 0.0);
  // The same build algorithm at another width may pick another triangle on a
  // tie or an edge, never many.
  EXPECT_NEAR(avx2_16->accuracy.same_hit, flat16->accuracy.same_hit, 0.002);
}

// tile8 and tile16 build the tile kernel at that width, tile-ab with the
// A/B defines: each is validated bit for bit like the default tile rows.
TEST(Peers, LaneWidthsAndABDefinesAreExactRows) {
  PeerOptions opt = small_run(64, 36);
  opt.variants = {"tile8", "tile16", "tile-ab"};
  opt.ab_defines = "-DRF_KEEP_EACH_GROUP=0";  // every group narrowed from its ends only: other visits, same bits
  const PeerReport r = run_peers(opt);
  EXPECT_TRUE(r.valid());
  const char* names[] = {"OpenCL tile 8 lanes", "OpenCL tile 16 lanes", "OpenCL tile with the A/B defines"};
  for (int v = 0; v < 3; ++v)
    for (int f = 0; f < 4; ++f) {
      const PeerRow& row = r.rows[static_cast<size_t>(4 * v + f)];
      EXPECT_EQ(row.variant, names[v]);
      EXPECT_TRUE(row.exact);
      EXPECT_EQ(row.mismatched_pixels, 0u) << row.variant << " " << row.fold;
    }
  // The A/B build is compared with, never the headline's rayfold.
  for (int f = 0; f < 4; ++f) EXPECT_TRUE(r.rows[static_cast<size_t>(8 + f)].measurement_only);
  const PeerRatios q = peer_ratios(r);
  ASSERT_NE(q.fastest_rayfold, nullptr);
  EXPECT_FALSE(q.fastest_rayfold->measurement_only) << q.fastest_rayfold->variant;
  // tile-ab runs at the device's width, which the report names.
  EXPECT_TRUE(r.tile_lanes == 8u || r.tile_lanes == 16u) << r.tile_lanes;
  EXPECT_EQ(run_peers([&] {
              PeerOptions forced = opt;
              forced.variants = {"tile8"};
              return forced;
            }())
                .tile_lanes,
            0u);  // forced widths only: the device's own is not what was timed
}

// What the A/B rows rest on: a forced width and extra defines reach the
// kernels' build (a define that cannot build fails the renderer), so a row
// named for them is not the default kernel again.
TEST(Peers, KernelTuningReachesTheKernelsBuild) {
  const Scene scene = load_gltf(std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb");
  for (unsigned lanes : {8u, 16u}) {
    PipelineOptions ro;
    ro.tuning.tile_lanes = lanes;
    EXPECT_EQ(Pipeline(scene, ro).tile_lanes(), lanes);
  }
  PipelineOptions cpu;
  cpu.backend = Backend::cpu;
  EXPECT_EQ(Pipeline(scene, cpu).tile_lanes(), 0u);
  PipelineOptions bad;
  bad.tuning.defines = "-DRF_LANES=3";  // rf_lanes.h's #error
  EXPECT_THROW(Pipeline(scene, bad), RuntimeFailure);
}

TEST(MachineInfo, ParsesTheFirstProcessor) {
  const std::string two =
      "processor\t: 0\nvendor_id\t: AuthenticAMD\nmodel name\t: AMD EPYC 9B14 96-Core Processor\n"
      "flags\t\t: fpu sse4_2 avx avx2 avx512f avx512vl\n\n"
      "processor\t: 1\nmodel name\t: Other\nflags\t\t: fpu\n";
  const MachineInfo m = parse_cpuinfo(two);
  EXPECT_EQ(m.cpu_model, "AMD EPYC 9B14 96-Core Processor");
  EXPECT_EQ(m.isa, "AVX-512");
  EXPECT_EQ(machine_label(m), "AMD EPYC 9B14 96-Core Processor (AVX-512)");
  EXPECT_EQ(parse_cpuinfo("model name : Zen 2\nflags : sse4_2 avx avx2\n").isa, "AVX2");
  EXPECT_EQ(parse_cpuinfo("model name : Old\nflags : sse4_2 avx\n").isa, "AVX");
  // A word that merely contains a flag's name is not that flag.
  EXPECT_EQ(parse_cpuinfo("flags : sse4_2 avx512_vnni\n").isa, "SSE4.2");
  const MachineInfo none = parse_cpuinfo("");
  EXPECT_EQ(none.cpu_model, "unknown CPU");
  EXPECT_EQ(none.isa, "unknown ISA");
  // "model name" is the key, not "model".
  EXPECT_EQ(parse_cpuinfo("model\t\t: 106\nmodel name\t: X\n").cpu_model, "X");
}

TEST(Peers, AMismatchInvalidatesTheReport) {
  PeerReport r;
  PeerRow exact;
  exact.variant = "OpenCL tile";
  exact.fold = "xy";
  exact.ms = 1.0;
  exact.pixels = 1000;
  exact.exact = true;
  r.rows.push_back(exact);
  EXPECT_TRUE(r.valid());
  r.rows[0].mismatched_pixels = 3;
  EXPECT_FALSE(r.valid());
  const std::string md = peers_markdown(r);
  EXPECT_NE(md.find("NOT EXACT: 3 pixels differ"), std::string::npos) << md;
  EXPECT_EQ(md.find("Fastest exact rayfold"), std::string::npos) << md;
}

// --rays: each workload's rays counted, rayfold exact against its CPU
// reference, Embree agreeing on nearly every ray, and a mismatch voids it.
TEST(Peers, RayQueriesAgainstEmbreeOnTheSameRays) {
  PeerOptions opt = small_run(40, 24);
  opt.random = true;
  opt.seed = 9;
  opt.views = 2;
  const RayPeerReport r = run_ray_peers(opt, 3000);
  ASSERT_EQ(r.rows.size(), 3u);
  EXPECT_EQ(r.rows[0].workload, "incoherent");
  EXPECT_EQ(r.rows[0].rays, 3000u);
  EXPECT_EQ(r.rows[1].rays, 40u * 24u);
  for (const RayPeerRow& row : r.rows) {
    EXPECT_EQ(row.mismatched_rays, 0u) << row.workload;
    EXPECT_GT(row.rayfold_ms, 0.0) << row.workload;
    EXPECT_GT(row.hit_share, 0.05) << row.workload;
    if (EmbreePeer::available()) {
      EXPECT_GT(row.embree1_ms, 0.0) << row.workload;
      EXPECT_GT(row.embree16_ms, 0.0) << row.workload;
      EXPECT_GT(row.hit_agreement, 0.99) << row.workload;
      EXPECT_GT(row.same_triangle, 0.98) << row.workload;
      EXPECT_NEAR(row.vs_embree(), std::min(row.embree1_ms, row.embree16_ms) / row.rayfold_ms, 1e-12);
    }
  }
  EXPECT_TRUE(r.valid());
  RayPeerReport bad = r;
  bad.rows[1].mismatched_rays = 1;
  EXPECT_FALSE(bad.valid());
  EXPECT_NE(ray_peers_markdown(bad).find("1 rays differ"), std::string::npos);
}

// The first G-buffer says whether its kernels were compiled or taken from
// rayfold's kernel cache: a fresh cache, then the same again.
TEST(Peers, FirstGBufferSaysWhereItsKernelsCameFrom) {
  const std::string dir = ::testing::TempDir() + "rayfold-peers-kcache-" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  setenv("RAYFOLD_KERNEL_CACHE", dir.c_str(), 1);
  PeerOptions opt = small_run(32, 18);
  opt.views = 1;
  opt.variants = {"tile"};
  const PeerReport cold = run_peers(opt), warm = run_peers(opt);
  unsetenv("RAYFOLD_KERNEL_CACHE");
  std::filesystem::remove_all(dir);
  EXPECT_FALSE(cold.rayfold_first_gbuffer.kernels_cached);
  EXPECT_TRUE(warm.rayfold_first_gbuffer.kernels_cached);
  EXPECT_NE(peers_markdown(cold).find("with its kernels built"), std::string::npos) << peers_markdown(cold);
  EXPECT_NE(peers_markdown(warm).find("with its kernels from rayfold's kernel cache"), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(peers_json(warm))["rayfold_first_gbuffer"]["kernels_cached"], true);
}

// Embree's frames write the G-buffer rayfold's do (unit world normal in
// rayfold's orientation, barycentrics), so that the two do the same work
// per pixel: on every pixel where both find the same triangle, flat and
// instanced scenes, single rays and packets, over mirrored and non-uniformly
// scaled instances.
TEST(Peers, EmbreeWritesRayfoldsGBuffer) {
  if (!EmbreePeer::available()) GTEST_SKIP() << "rayfold was built without Embree";
  testing::Rng rng(7);
  const Scene scene = testing::random_scene(rng, 3, 12, 200);
  PipelineOptions opt;
  opt.backend = Backend::cpu;
  Pipeline cpu(scene, opt);
  EmbreePeer embree(scene, cpu.scene_data(), 2);
  size_t compared = 0;
  for (int v = 0; v < 3; ++v) {
    const Camera cam = make_camera(testing::random_camera(rng, scene.world_bounds()), 80, 48);
    const HitBuffer want = cpu.render(cam).hits;
    embree.set_camera(cam);
    for (EmbreeScene which : {EmbreeScene::flat, EmbreeScene::instanced, EmbreeScene::flat_high})
      for (int packets = 0; packets < 2; ++packets) {
        std::vector<rf_pixel_hit> got;
        packets ? embree.trace16(got, which) : embree.trace1(got, which);
        ASSERT_EQ(got.size(), want.size());
        for (size_t i = 0; i < got.size(); ++i) {
          const rf_pixel_hit &g = got[i], &w = want[i];
          if (g.instance == RF_INVALID) {
            EXPECT_TRUE(g.nx == 0.0f && g.ny == 0.0f && g.nz == 0.0f && g.u == 0.0f && g.v == 0.0f) << "pixel " << i;
            continue;
          }
          if (g.instance != w.instance || g.primitive != w.primitive) continue;
          ++compared;
          const float dot = g.nx * w.nx + g.ny * w.ny + g.nz * w.nz;
          EXPECT_GT(dot, 0.9999f) << "view " << v << " scene " << int(which) << " packets " << packets << " pixel "
                                  << i << ": normal (" << g.nx << ", " << g.ny << ", " << g.nz << ") against ("
                                  << w.nx << ", " << w.ny << ", " << w.nz << ")";
          EXPECT_NEAR(g.nx * g.nx + g.ny * g.ny + g.nz * g.nz, 1.0f, 1e-5f) << "pixel " << i << ": not unit length";
          EXPECT_NEAR(g.u, w.u, 1e-3) << "pixel " << i;
          EXPECT_NEAR(g.v, w.v, 1e-3) << "pixel " << i;
        }
      }
  }
  EXPECT_GT(compared, 2000u);
  // Ray queries (rayfold-peers --rays) the same, with z = t.
  const Aabb b = scene.world_bounds();
  const size_t n = 4000;
  std::vector<float> o(3 * n), d(3 * n);
  for (size_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) {
      o[3 * i + k] = rng.uniformf(b.lo[k], b.hi[k]);
      d[3 * i + k] = rng.uniformf(-1.0f, 1.0f);
    }
  std::vector<rf_pixel_hit> want(n);
  cpu.intersect(o.data(), d.data(), n, 0.0f, INFINITY, false, FrameOptions{}, want.data());
  compared = 0;
  size_t misses = 0;
  // Single rays, packets of consecutive rays, and packets of 4x4 blocks of
  // rays taken as an image's rows of 50.
  for (int packets = 0; packets < 3; ++packets) {
    std::vector<rf_pixel_hit> got;
    packets ? embree.intersect16(o.data(), d.data(), n, packets == 2 ? 50 : 0, got, EmbreeScene::flat)
            : embree.intersect1(o.data(), d.data(), n, got, EmbreeScene::flat);
    for (size_t i = 0; i < n; ++i) {
      const rf_pixel_hit &g = got[i], &w = want[i];
      if (g.instance == RF_INVALID) {
        ++misses;
        EXPECT_TRUE(g.z == INFINITY && g.nx == 0.0f && g.u == 0.0f && g.v == 0.0f && g.primitive == RF_INVALID)
            << "ray " << i;
        continue;
      }
      if (g.instance != w.instance || g.primitive != w.primitive) continue;
      ++compared;
      EXPECT_GT(g.nx * w.nx + g.ny * w.ny + g.nz * w.nz, 0.9999f) << "ray " << i << " packets " << packets;
      EXPECT_NEAR(g.z, w.z, 1e-3 * w.z) << "ray " << i;  // t itself, not t |d| (near hits round by |o| / t)
      EXPECT_NEAR(g.u, w.u, 1e-3) << "ray " << i;
      EXPECT_NEAR(g.v, w.v, 1e-3) << "ray " << i;
    }
  }
  EXPECT_GT(compared, 1500u);
  EXPECT_GT(misses, 100u);
}

}  // namespace
}  // namespace rayfold::core
