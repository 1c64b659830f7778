#include "pipeline/auto_frame.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include <glm/geometric.hpp>

#include "pipeline/pipeline.h"

namespace rayfold::core {
namespace {

constexpr int kFrameProbeWidth = 64, kFrameProbeHeight = 36;
constexpr int kAzimuths = 8;

// The eye at fraction f of the bounds on each axis.
glm::dvec3 point_in(const Aabb& b, const glm::dvec3& f) {
  const glm::dvec3 lo(b.lo), hi(b.hi);
  return lo + f * (hi - lo);
}

// The centre (p = 0), then the centres of the eight octants (p = 1..8).
glm::dvec3 probe_fractions(int p) {
  glm::dvec3 f(0.5);
  if (p > 0)
    for (int a = 0; a < 3; ++a) f[a] = ((p - 1) >> a) & 1 ? 0.75 : 0.25;
  return f;
}

}  // namespace

Probe probe(Pipeline& cpu, const CameraSpec& spec, int width, int height) {
  const Camera cam = make_camera(spec, width, height);
  const RenderResult r = cpu.render(cam);
  size_t hits = 0;
  std::vector<double> front_depths;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const rf_pixel_hit& h = r.hits[static_cast<size_t>(y) * width + x];
      if (h.instance == RF_INVALID) continue;
      ++hits;
      const glm::dvec3 d = glm::dvec3(cam.world_from_camera * glm::dvec4(exact_direction(cam, x, y), 0.0));
      if (glm::dot(glm::dvec3(h.nx, h.ny, h.nz), d) < 0.0) front_depths.push_back(h.z);
    }
  Probe p;
  p.hit_fraction = static_cast<double>(hits) / (static_cast<double>(width) * height);
  p.front_fraction = hits ? static_cast<double>(front_depths.size()) / hits : 0.0;
  if (!front_depths.empty()) {
    auto mid = front_depths.begin() + front_depths.size() / 2;
    std::nth_element(front_depths.begin(), mid, front_depths.end());
    p.median_front_depth = *mid;
  }
  return p;
}

glm::dvec3 up_for(const glm::dvec3& eye, const glm::dvec3& target) {
  const glm::dvec3 f = glm::normalize(target - eye);
  return std::fabs(f.y) > 0.999 ? glm::dvec3(0.0, 0.0, 1.0) : glm::dvec3(0.0, 1.0, 0.0);
}

ViewKind classify_scene(const Scene& scene, Pipeline& cpu) {
  const Aabb b = scene.world_bounds();
  if (b.empty()) return ViewKind::object;
  const glm::dvec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  // The centre and the centres of the eight octants: an object that merely
  // has a cavity at its centre (a car's cabin) sees little from most of them.
  double centre = 0.0, centre_back = 0.0, octants = 0.0;
  for (int p = 0; p < 9; ++p) {
    const glm::dvec3 eye = point_in(b, probe_fractions(p));
    for (const glm::dvec3& a : axes) {
      CameraSpec c;
      c.eye = eye;
      c.look_at = eye + a;
      c.up = up_for(c.eye, c.look_at);
      c.vfov_degrees = 90.0;
      const Probe pr = probe(cpu, c, 32, 32);
      (p == 0 ? centre : octants) += pr.hit_fraction * pr.front_fraction / (p == 0 ? 6.0 : 48.0);
      if (p == 0) centre_back += pr.hit_fraction * (1.0 - pr.front_fraction) / 6.0;
    }
  }
  return (centre >= 0.6 || centre_back >= 0.6) && octants >= 0.5 ? ViewKind::interior : ViewKind::object;
}

AutoFrame auto_frame(const Scene& scene, Pipeline& cpu, double vfov_degrees) {
  AutoFrame out;
  out.spec = frame_bounds(scene.world_bounds(), vfov_degrees);
  out.kind = classify_scene(scene, cpu);
  if (out.kind == ViewKind::object) return out;
  const Aabb b = scene.world_bounds();
  // Score: the front faces seen, times how far away they are (the median), so
  // that a view down the room beats a view of the wall beside the eye. An
  // eye whose views see mostly back faces is inside something solid; the
  // octants' centres are tried only when the centre is.
  double best = -1.0;
  bool best_clear = false;
  for (int p = 0; p < 9; ++p) {
    const glm::dvec3 eye = point_in(b, probe_fractions(p));
    double front_sum = 0.0;
    CameraSpec eye_best;
    double eye_score = -1.0;
    for (int k = 0; k < kAzimuths; ++k) {
      const double azimuth = 2.0 * M_PI * k / kAzimuths;
      CameraSpec c;
      c.eye = eye;
      c.look_at = eye + glm::dvec3(std::sin(azimuth), 0.0, -std::cos(azimuth));
      c.up = glm::dvec3(0.0, 1.0, 0.0);
      c.vfov_degrees = vfov_degrees;
      const Probe pr = probe(cpu, c, kFrameProbeWidth, kFrameProbeHeight);
      front_sum += pr.hit_fraction * pr.front_fraction;
      const double score = pr.hit_fraction * pr.front_fraction * pr.median_front_depth;
      if (score > eye_score) {
        eye_score = score;
        eye_best = c;
      }
    }
    const bool clear = front_sum / kAzimuths >= 0.5;
    if ((clear && !best_clear) || (clear == best_clear && eye_score > best)) {
      best = eye_score;
      best_clear = clear;
      out.spec = eye_best;
    }
    if (best_clear) break;
  }
  return out;
}

}  // namespace rayfold::core
