// Embree 3 as the peer in the speed/accuracy benchmark, in two scenes:
//  - instanced: the same two levels as rayfold, instances of per-mesh scenes
//    with camera_from_object transforms and a top level rebuilt per camera,
//    traced with the very same camera-space float rays rayfold generates;
//  - flat: every instance's triangles moved to world space in one scene
//    built once, as a user with a static scene builds it, traced with the
//    same rays turned to world space; built twice, at Embree's default
//    quality (MEDIUM) and at RTC_BUILD_QUALITY_HIGH, which traces up to 1.3x
//    faster on some scenes and builds slower.
// Both with rtcIntersect1 and with coherent rtcIntersect16 packets of 4x4
// pixels. Built only when Embree is installed.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "fold/frame.h"
#include "scene/camera.h"
#include "scene/scene.h"

namespace rayfold::core {

enum class EmbreeScene { instanced, flat, flat_high };

class EmbreePeer {
 public:
  // False when rayfold was built without Embree; the peer then says so.
  static bool available();

  // isa: Embree's `isa=` configuration ("avx2": the AVX2 kernels on an
  // AVX-512 CPU, which tells what the ISA buys Embree from what the core
  // does); empty: Embree's own choice. flat_only: the flat default-quality
  // scene alone (traced as EmbreeScene::flat), for such an extra row.
  EmbreePeer(const Scene& scene, const SceneData& data, unsigned threads, const std::string& isa = "",
             bool flat_only = false);
  ~EmbreePeer();

  // The vector ISA Embree's device traces with, from its native packet
  // widths and the host's ISA: "AVX-512", "AVX2", "AVX" or "SSE".
  std::string isa(const std::string& host_isa) const;

  // Moves the instances to this camera's space and rebuilds the top level.
  void set_camera(const Camera& camera);
  // The flat scenes' build (rtcCommitScene) in ms; 0 for the instanced one.
  double build_ms(EmbreeScene scene) const;
  // A flat scene built again from nothing at that scene's quality, then
  // released: its rtcCommitScene in ms (the builds' medians, alternated
  // with rayfold's, in rayfold-peers --build-rounds).
  double rebuild_ms(EmbreeScene scene);
  // The same builds' peak resident memory (tools/bench/peak_memory.h), bytes.
  size_t build_peak_bytes(EmbreeScene scene) const;
  // Every pixel's G-buffer as rayfold's (distance, world-space unit
  // geometric normal in rayfold's orientation, barycentrics, instance,
  // primitive), so that both frames do the same work. Returns ms.
  double trace1(std::vector<rf_pixel_hit>& hits, EmbreeScene scene);
  double trace16(std::vector<rf_pixel_hit>& hits, EmbreeScene scene);
  // Ray queries on a flat scene (world space), as Pipeline::intersect takes
  // them (n x 3 origins and directions): each ray's t along its direction
  // (z), normal, barycentrics, instance and primitive, or a miss. rtcIntersect1 ray by ray; or
  // rtcIntersect16 packets: 4x4 blocks of an image's rays (rows of
  // row_length, marked coherent), else 16 consecutive rays. Returns ms.
  double intersect1(const float* origins, const float* directions, size_t n, std::vector<rf_pixel_hit>& hits,
                    EmbreeScene scene);
  double intersect16(const float* origins, const float* directions, size_t n, size_t row_length,
                     std::vector<rf_pixel_hit>& hits, EmbreeScene scene);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rayfold::core
