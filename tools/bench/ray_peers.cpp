#include "bench/ray_peers.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>

#include <nlohmann/json.hpp>

#include "bench/bench.h"
#include "bench/embree_peer.h"
#include "pipeline/pipeline.h"
#include "scene/gltf_loader.h"
#include "fixtures/splitmix.h"
#include "util/timer.h"

namespace rayfold::core {
namespace {

struct Workload {
  std::string name;
  std::vector<float> o, d;
  size_t row_length = 0;  // an image's width, 0 for scattered rays
  size_t size() const { return o.size() / 3; }
};

Workload incoherent(const Scene& scene, size_t n, uint64_t seed) {
  Workload w;
  w.name = "incoherent";
  const Aabb b = scene.world_bounds();
  SplitMix rng(seed);
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) w.o.push_back(static_cast<float>(rng.uniform(b.lo[k], b.hi[k])));
    double d[3], len;
    do {  // uniform on the sphere: a point of the ball, pushed out
      for (double& c : d) c = rng.uniform(-1.0, 1.0);
      len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    } while (len > 1.0 || len < 1e-3);
    for (double c : d) w.d.push_back(static_cast<float>(c / len));
  }
  return w;
}

// Every pixel's ray of the view in world space, as EmbreePeer's flat scene
// takes them: the eye, and the camera-space ray turned by world_from_camera.
Workload view_rays(const Camera& cam, const std::string& name) {
  Workload w;
  w.name = name;
  w.row_length = static_cast<size_t>(cam.width);
  const rf_camera& c = cam.params;
  float eye[3], m[3][3];
  for (int r = 0; r < 3; ++r) {
    eye[r] = static_cast<float>(cam.world_from_camera[3][r]);
    for (int k = 0; k < 3; ++k) m[r][k] = static_cast<float>(cam.world_from_camera[k][r]);
  }
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const float cd[3] = {c.scale_x * (static_cast<float>(2 * x + c.kx0) + c.frac_x),
                           c.scale_y * (static_cast<float>(c.ky0 - 2 * y) + c.frac_y), -1.0f};
      for (int r = 0; r < 3; ++r) {
        w.o.push_back(eye[r]);
        w.d.push_back(m[r][0] * cd[0] + m[r][1] * cd[1] + m[r][2] * cd[2]);
      }
    }
  return w;
}

}  // namespace

double RayPeerRow::vs_embree() const {
  double best = 0.0;
  for (double ms : {embree1_ms, embree16_ms})
    if (ms > 0.0 && (best == 0.0 || ms < best)) best = ms;
  return best > 0.0 && rayfold_ms > 0.0 ? best / rayfold_ms : 0.0;
}

bool RayPeerReport::valid() const {
  for (const RayPeerRow& r : rows)
    if (r.mismatched_rays != 0) return false;
  return true;
}

RayPeerReport run_ray_peers(const PeerOptions& opt, size_t incoherent_rays) {
  const Scene scene = load_gltf(opt.scene);
  PipelineOptions ro;
  ro.threads = opt.threads;
  ro.device_hint = opt.device_hint;
  Pipeline ours(scene, ro);
  ro.backend = Backend::cpu;
  Pipeline reference(scene, ro, ours.shared_scene_data());
  RayPeerReport rep;
  std::unique_ptr<EmbreePeer> embree;
  if (EmbreePeer::available())
    embree = std::make_unique<EmbreePeer>(scene, ours.scene_data(), opt.threads);
  else
    rep.embree_note = "rayfold was built without Embree: its columns are empty (install libembree-dev).";

  std::vector<Workload> work;
  if (incoherent_rays > 0) work.push_back(incoherent(scene, incoherent_rays, opt.seed));
  const std::vector<CameraSpec> path = camera_path(scene, opt);
  for (size_t v = 0; v < path.size(); ++v)
    work.push_back(view_rays(make_camera(path[v], opt.width, opt.height), "view " + std::to_string(v)));

  const EmbreeScene flats[] = {EmbreeScene::flat, EmbreeScene::flat_high};
  for (const Workload& w : work) {
    RayPeerRow row;
    row.workload = w.name;
    row.rays = w.size();
    std::vector<rf_pixel_hit> got(w.size()), want(w.size());
    ours.intersect(w.o.data(), w.d.data(), w.size(), 0.0f, INFINITY, false, FrameOptions{}, got.data(), w.row_length);
    reference.intersect(w.o.data(), w.d.data(), w.size(), 0.0f, INFINITY, false, FrameOptions{}, want.data());
    size_t hits = 0;
    for (size_t i = 0; i < w.size(); ++i) {
      row.mismatched_rays += std::memcmp(&got[i], &want[i], sizeof got[i]) != 0;
      hits += got[i].instance != RF_INVALID;
    }
    row.hit_share = static_cast<double>(hits) / static_cast<double>(std::max<size_t>(1, w.size()));
    std::vector<double> ours_ms, e1[2], e16[2];
    std::vector<rf_pixel_hit> peer;
    for (int f = -opt.warmup; f < opt.frames; ++f) {
      const auto t0 = Clock::now();
      ours.intersect(w.o.data(), w.d.data(), w.size(), 0.0f, INFINITY, false, FrameOptions{}, got.data(),
                     w.row_length);
      const double ms = ms_since(t0);
      if (f >= 0) ours_ms.push_back(ms);
      if (!embree) continue;
      for (int s = 0; s < 2; ++s) {
        const double a = embree->intersect1(w.o.data(), w.d.data(), w.size(), peer, flats[s]);
        const double b = embree->intersect16(w.o.data(), w.d.data(), w.size(), w.row_length, peer, flats[s]);
        if (f >= 0) {
          e1[s].push_back(a);
          e16[s].push_back(b);
        }
      }
    }
    row.rayfold_ms = median(ours_ms);
    if (embree) {
      row.embree1_ms = std::min(median(e1[0]), median(e1[1]));
      row.embree16_ms = std::min(median(e16[0]), median(e16[1]));
      embree->intersect1(w.o.data(), w.d.data(), w.size(), peer, EmbreeScene::flat);
      size_t agree = 0, both = 0, same = 0;
      for (size_t i = 0; i < w.size(); ++i) {
        const bool a = got[i].instance != RF_INVALID, b = peer[i].instance != RF_INVALID;
        agree += a == b;
        both += a && b;
        same += a && b && got[i].instance == peer[i].instance && got[i].primitive == peer[i].primitive;
      }
      row.hit_agreement = static_cast<double>(agree) / static_cast<double>(std::max<size_t>(1, w.size()));
      row.same_triangle = static_cast<double>(same) / static_cast<double>(std::max<size_t>(1, both));
    }
    rep.rows.push_back(row);
  }
  return rep;
}

std::string ray_peers_markdown(const RayPeerReport& rep) {
  std::string s =
      "\nRay queries (Renderer::intersect against Embree's flat scene on the same rays, both returning t, the "
      "unit normal, the barycentrics and the ids; ratio: Embree's faster of rtcIntersect1 and rtcIntersect16 over "
      "rayfold's time; rayfold checked bit for bit against its CPU reference first)\n\n"
      "| rays | count | hits | rayfold ms | Embree 1 ms | Embree 16 ms | vs Embree | hit agreement | same triangle | "
      "exact |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const RayPeerRow& r : rep.rows) {
    char line[400];
    std::snprintf(line, sizeof line, "| %s | %zu | %.0f%% | %.1f | %.1f | %.1f | **%.2fx** | %.4f | %.4f | %s |\n",
                  r.workload.c_str(), r.rays, 100.0 * r.hit_share, r.rayfold_ms, r.embree1_ms, r.embree16_ms,
                  r.vs_embree(), r.hit_agreement, r.same_triangle,
                  r.mismatched_rays == 0 ? "yes" : (std::to_string(r.mismatched_rays) + " rays differ").c_str());
    s += line;
  }
  if (!rep.embree_note.empty()) s += "\n" + rep.embree_note + "\n";
  return s;
}

std::string ray_peers_json(const RayPeerReport& rep) {
  nlohmann::json rows = nlohmann::json::array();
  for (const RayPeerRow& r : rep.rows)
    rows.push_back({{"workload", r.workload},
                    {"rays", r.rays},
                    {"hit_share", r.hit_share},
                    {"rayfold_ms", r.rayfold_ms},
                    {"embree_rtcIntersect1_ms", r.embree1_ms},
                    {"embree_rtcIntersect16_ms", r.embree16_ms},
                    {"vs_embree", r.vs_embree()},
                    {"hit_agreement", r.hit_agreement},
                    {"same_triangle", r.same_triangle},
                    {"mismatched_rays", r.mismatched_rays}});
  return rows.dump(1);
}

}  // namespace rayfold::core
