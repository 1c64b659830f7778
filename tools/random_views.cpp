#include "random_views.h"

#include <algorithm>
#include <cmath>

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include "cli_args.h"
#include "pipeline/pipeline.h"
#include "splitmix.h"
#include "scene/camera.h"
#include "util/errors.h"

namespace rayfold::core {
namespace {

constexpr int kProbeWidth = 64, kProbeHeight = 36;
constexpr int kMaxDraws = 200;

glm::dvec3 in_box(SplitMix& rng, const glm::dvec3& lo, const glm::dvec3& hi) {
  const double x = rng.uniform(lo.x, hi.x), y = rng.uniform(lo.y, hi.y), z = rng.uniform(lo.z, hi.z);
  return {x, y, z};
}

struct Probe {
  double hit_fraction = 0.0;
  double front_fraction = 0.0;  // of the hits
};

// Traces the view at the probe's size: how much it sees, and how much of it
// from the front (the world normal against the world ray).
Probe probe(Pipeline& cpu, const CameraSpec& spec, int width, int height) {
  const Camera cam = make_camera(spec, width, height);
  const RenderResult r = cpu.render(cam);
  size_t hits = 0, front = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const rf_pixel_hit& h = r.hits[static_cast<size_t>(y) * width + x];
      if (h.instance == RF_INVALID) continue;
      ++hits;
      const glm::dvec3 d = glm::dvec3(cam.world_from_camera * glm::dvec4(exact_direction(cam, x, y), 0.0));
      front += glm::dot(glm::dvec3(h.nx, h.ny, h.nz), d) < 0.0;
    }
  Probe p;
  p.hit_fraction = static_cast<double>(hits) / (static_cast<double>(width) * height);
  p.front_fraction = hits ? static_cast<double>(front) / hits : 0.0;
  return p;
}

// Up must not be parallel to the view direction; +y unless the view looks
// (nearly) straight up or down.
glm::dvec3 up_for(const glm::dvec3& eye, const glm::dvec3& target) {
  const glm::dvec3 f = glm::normalize(target - eye);
  return std::fabs(f.y) > 0.999 ? glm::dvec3(0.0, 0.0, 1.0) : glm::dvec3(0.0, 1.0, 0.0);
}

}  // namespace

const char* view_kind_name(ViewKind k) {
  switch (k) {
    case ViewKind::automatic:
      return "auto";
    case ViewKind::interior:
      return "interior";
    case ViewKind::object:
      return "object";
  }
  return "?";
}

ViewKind parse_view_kind(const std::string& flag, const std::string& v) {
  if (v == "auto") return ViewKind::automatic;
  if (v == "interior") return ViewKind::interior;
  if (v == "object") return ViewKind::object;
  throw UsageError(flag + ": expected auto, interior or object, got '" + v + "'");
}

ViewKind classify_scene(const Scene& scene, Pipeline& cpu) {
  const Aabb b = scene.world_bounds();
  if (b.empty()) return ViewKind::object;
  const glm::dvec3 lo = glm::dvec3(b.lo), hi = glm::dvec3(b.hi);
  const glm::dvec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  // The centre and the centres of the eight octants: an object that merely
  // has a cavity at its centre (a car's cabin) sees little from most of them.
  double centre = 0.0, octants = 0.0;
  for (int p = 0; p < 9; ++p) {
    glm::dvec3 f(0.5);
    if (p > 0)
      for (int a = 0; a < 3; ++a) f[a] = ((p - 1) >> a) & 1 ? 0.75 : 0.25;
    const glm::dvec3 eye = lo + f * (hi - lo);
    for (const glm::dvec3& a : axes) {
      CameraSpec c;
      c.eye = eye;
      c.look_at = eye + a;
      c.up = up_for(c.eye, c.look_at);
      c.vfov_degrees = 90.0;
      const Probe pr = probe(cpu, c, 32, 32);
      (p == 0 ? centre : octants) += pr.hit_fraction * pr.front_fraction / (p == 0 ? 6.0 : 48.0);
    }
  }
  return centre >= 0.6 && octants >= 0.5 ? ViewKind::interior : ViewKind::object;
}

RandomViews random_views(const Scene& scene, Pipeline& cpu, int count, uint64_t seed, ViewKind kind) {
  RandomViews out;
  out.kind = kind == ViewKind::automatic ? classify_scene(scene, cpu) : kind;
  const Aabb b = scene.world_bounds();
  if (b.empty()) throw InputError("", "random views: the scene has no geometry to look at");
  const glm::dvec3 lo = glm::dvec3(b.lo), hi = glm::dvec3(b.hi), centre = 0.5 * (lo + hi);
  const double diagonal = glm::length(hi - lo), radius = 0.5 * diagonal;
  const glm::dvec3 margin = 0.1 * (hi - lo);
  const bool interior = out.kind == ViewKind::interior;
  const double min_hits = interior ? 0.5 : 0.25;
  SplitMix rng(seed);
  for (int v = 0; v < count; ++v) {
    CameraSpec best;
    double best_score = -1.0, best_hits = 0.0;
    bool met = false;
    for (int draw = 0; draw < kMaxDraws && !met; ++draw) {
      CameraSpec c;
      if (interior) {
        c.eye = in_box(rng, lo + margin, hi - margin);
        do c.look_at = in_box(rng, lo, hi);
        while (glm::length(c.look_at - c.eye) < 0.1 * diagonal);
      } else {
        const double azimuth = rng.uniform(0.0, 2.0 * M_PI);
        const double elevation = glm::radians(rng.uniform(-20.0, 70.0));
        const double distance = rng.uniform(1.2, 3.0) * radius;
        c.eye = centre + distance * glm::dvec3(std::cos(elevation) * std::cos(azimuth), std::sin(elevation),
                                               std::cos(elevation) * std::sin(azimuth));
        const double r = 0.25 * radius * std::cbrt(rng.uniform(0.0, 1.0));
        const glm::dvec3 dir = glm::dvec3(rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(-1.0, 1.0));
        c.look_at = centre + (glm::length(dir) > 0.0 ? r * glm::normalize(dir) : glm::dvec3(0.0));
      }
      c.up = up_for(c.eye, c.look_at);
      c.vfov_degrees = rng.uniform(40.0, 90.0);
      const Probe p = probe(cpu, c, kProbeWidth, kProbeHeight);
      met = p.hit_fraction >= min_hits && (!interior || p.front_fraction >= 0.5);
      const double score = p.hit_fraction * (interior ? p.front_fraction : 1.0);
      if (met || score > best_score) {
        best = c;
        best_score = score;
        best_hits = p.hit_fraction;
      }
      if (!met) ++out.redrawn;
    }
    if (!met) ++out.below_threshold;
    out.cameras.push_back(best);
    out.hit_fraction.push_back(best_hits);
  }
  return out;
}

}  // namespace rayfold::core
