// `rayfold-peers --rays N`: ray queries from anywhere against Embree on the
// same rays. Workloads: N incoherent rays (origins uniform in the scene's
// bounds, directions uniform on the sphere) and every view's pixel rays as
// an image's array (rows of the width, one origin). rayfold's
// Pipeline::intersect on the OpenCL device (the query tile kernel for the
// views, the single-ray kernel for the incoherent rays), checked bit for
// bit against the CPU reference's answers first, against Embree's flat
// world-space scene (default and high build quality, the faster counting)
// with rtcIntersect1 and with rtcIntersect16 packets, each median of the
// frames after the warm-up, all taking turns frame by frame.
#pragma once

#include <string>
#include <vector>

#include "bench/peers.h"

namespace rayfold::core {

struct RayPeerRow {
  std::string workload;  // "incoherent", "view 0", ...
  size_t rays = 0;
  double hit_share = 0.0;    // rayfold's rays that hit
  double rayfold_ms = 0.0;   // median per batch
  double embree1_ms = 0.0;   // rtcIntersect1, the faster of the two flat scenes (0: no Embree)
  double embree16_ms = 0.0;  // rtcIntersect16, likewise
  // Embree's answers against rayfold's: hit or miss the same, and the same
  // instance and primitive where both hit (rtcIntersect1, default scene).
  double hit_agreement = 0.0, same_triangle = 0.0;
  size_t mismatched_rays = 0;  // rayfold OpenCL against its CPU reference (must be 0)
  double vs_embree() const;    // Embree's faster time over rayfold's; 0 without Embree
};

struct RayPeerReport {
  std::vector<RayPeerRow> rows;
  std::string embree_note;
  bool valid() const;
};

RayPeerReport run_ray_peers(const PeerOptions& options, size_t incoherent_rays);
std::string ray_peers_markdown(const RayPeerReport& report);
std::string ray_peers_json(const RayPeerReport& report);  // a JSON array of the rows

}  // namespace rayfold::core
