// `rayfold-peers`: speed against accuracy, side by side in one run. Every
// variant (rayfold's OpenCL exact and fast builds and its CPU reference, in
// every fold mode, and Embree's rtcIntersect1 and rtcIntersect16 packets when
// installed) traces the same views; each image is measured against the
// double-precision reference (host/reference/double_reference.h).
#pragma once

#include <optional>
#include <set>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "bench/bench.h"
#include "bench/machine_info.h"
#include "reference/accuracy.h"

namespace rayfold::core {

struct PeerOptions : ViewPath {
  unsigned threads = 2;
  std::string device_hint;
  // rayfold's rows: tile, single (the single-ray kernel), fast (the tile
  // kernel's fast build), cpu (the CPU reference, timed; it validates every
  // exact row whether timed or not).
  // tile8, tile16: the tile kernel with that many lanes; tile-ab: built with
  // ab_defines too, to measure a kernel change against the tree's in one run.
  std::set<std::string> variants{"tile", "single", "fast", "exact-depth", "cpu"};
  std::string ab_defines;
  bool merge = true;  // static instances of one transform share a tree (MergeOptions)
  // Bottom-level builds timed: rayfold's and Embree's flat default and high
  // quality builds alternated this many times, medians reported.
  int build_rounds = 5;
};

struct PeerRow {
  std::string variant;  // "OpenCL exact", "OpenCL fast", "CPU reference", "Embree rtcIntersect1", ...
  std::string fold;     // none, y, x, xy ("-" for Embree)
  double ms = 0.0;      // per frame, mean over views of per-view medians
  double rays = 0.0;    // traced per frame
  double pixels = 0.0;  // answered per frame
  Accuracy accuracy;    // same_hit, hit_miss: mean over views; depth: median of medians, max of p99s and maxima
  bool exact = false;   // promised bit for bit equal to the CPU reference
  size_t mismatched_pixels = 0;  // exact rows: pixels that differ from it, over all views (must be 0)
  // A row to compare with, not a mode the headline ratios count: the tile
  // kernel with the A/B defines, Embree forced to AVX2.
  bool measurement_only = false;
};

// Time from nothing to one G-buffer: the file's load, the trees (rayfold:
// the whole renderer, device and programs included) and the first frame, ms.
struct FirstGbuffer {
  double load_ms = 0.0, build_ms = 0.0, frame_ms = 0.0;
  // rayfold: its programs came from the kernel cache (opencl/kernel_cache.h),
  // which a process's first G-buffer finds warm after the first run.
  bool kernels_cached = false;
  double total() const { return load_ms + build_ms + frame_ms; }
};

struct PeerReport {
  std::string scene, device, embree_note, views_note;
  MachineInfo machine;      // the CPU the figures are from
  unsigned tile_lanes = 0;  // the device's width, from the first tile variant built at it (0: only tile8/tile16 ran)
  std::string embree_isa;   // Embree's own choice; empty without Embree
  // On an AVX-512 CPU, Embree forced to AVX2 ("Embree flat AVX2" rows): what
  // the ISA buys Embree apart from what the core does. Empty elsewhere.
  std::string embree_avx2_note;
  std::vector<CameraSpec> cameras;  // the views traced
  int width = 0, height = 0, views = 0, frames = 0;
  unsigned threads = 0;
  size_t triangles = 0, instances = 0;
  // Bottom-level builds: rayfold's (every mesh's tree) against Embree's flat
  // scene at its default and its high quality (rtcCommitScene), in ms.
  double rayfold_build_ms = 0.0, embree_build_ms = 0.0, embree_high_build_ms = 0.0;  // medians of build_rounds
  int build_rounds = 0;
  // The same builds' peak resident memory per scene triangle (instances
  // counted each time, as Embree's flat scene holds them; tools/bench/peak_memory.h;
  // 0 where it cannot be measured), bytes.
  double rayfold_build_bytes = 0.0, embree_build_bytes = 0.0, embree_high_build_bytes = 0.0;
  // rayfold's first timed variant; Embree's default flat scene, whose load
  // (it has none of its own: it is handed rayfold's triangles) is 0.
  FirstGbuffer rayfold_first_gbuffer, embree_first_gbuffer;
  std::vector<PeerRow> rows;
  // False when an exact row differs from the CPU reference: no figure of
  // the report is then valid.
  bool valid() const;
};

// The headline comparison: rayfold's fastest exact OpenCL row against
// Embree's fastest row, and against Embree's fastest instanced row, in
// answered pixels per second (0 when a side is missing).
struct PeerRatios {
  const PeerRow* fastest_rayfold = nullptr;
  const PeerRow* fastest_embree = nullptr;
  const PeerRow* fastest_embree_instanced = nullptr;
  double vs_embree = 0.0, vs_embree_instanced = 0.0;
};
PeerRatios peer_ratios(const PeerReport& report);

PeerReport run_peers(const PeerOptions& options);
std::string peers_markdown(const PeerReport& report);
std::string peers_json(const PeerReport& report);

}  // namespace rayfold::core
