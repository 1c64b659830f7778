#include "reference/double_reference.h"

#include <algorithm>
#include <cmath>

#include "rf_alpha.h"
#include "rf_trace.h"
#include "util/parallel.h"

namespace rayfold::core {
namespace {

struct Ray {
  double o[3], d[3], invd[3];
  double sx, sy, sz;
  int kx, ky, kz;
};

Ray make_ray(const glm::dvec3& o, const glm::dvec3& d) {
  Ray r;
  for (int k = 0; k < 3; ++k) {
    r.o[k] = o[k];
    r.d[k] = d[k];
    r.invd[k] = 1.0 / (std::fabs(d[k]) < 1e-300 ? std::copysign(1e-300, d[k]) : d[k]);
  }
  int kz = 0;
  if (std::fabs(d[1]) > std::fabs(d[kz])) kz = 1;
  if (std::fabs(d[2]) > std::fabs(d[kz])) kz = 2;
  int kx = (kz + 1) % 3, ky = (kx + 1) % 3;
  if (d[kz] < 0.0) std::swap(kx, ky);
  r.kx = kx;
  r.ky = ky;
  r.kz = kz;
  r.sx = d[kx] / d[kz];
  r.sy = d[ky] / d[kz];
  r.sz = 1.0 / d[kz];
  return r;
}

// Float boxes contain their float vertices exactly; the small widening keeps
// the double slab test conservative whatever its own rounding.
double box_entry(const rf_node& n, const Ray& r, double tmax) {
  double tnear = 0.0, tfar = INFINITY;
  for (int k = 0; k < 3; ++k) {
    const double a = (n.bmin[k] - r.o[k]) * r.invd[k], b = (n.bmax[k] - r.o[k]) * r.invd[k];
    tnear = std::max(tnear, std::min(a, b));
    tfar = std::min(tfar, std::max(a, b));
  }
  tnear *= 1.0 - 1e-9;
  tfar *= 1.0 + 1e-9;
  return tnear <= std::min(tfar, tmax) ? tnear : INFINITY;
}

// The hit's t and its second and third vertices' weights (u, v).
bool triangle(const rf_tri& tri, const Ray& r, double* t, double* bu, double* bv) {
  const float* v[3] = {tri.v0, tri.v1, tri.v2};
  double px[3], py[3], pz[3];
  for (int i = 0; i < 3; ++i) {
    const double ax = v[i][r.kx] - r.o[r.kx], ay = v[i][r.ky] - r.o[r.ky], az = v[i][r.kz] - r.o[r.kz];
    px[i] = ax - r.sx * az;
    py[i] = ay - r.sy * az;
    pz[i] = r.sz * az;
  }
  const double u = px[2] * py[1] - py[2] * px[1];
  const double v_ = px[0] * py[2] - py[0] * px[2];
  const double w = px[1] * py[0] - py[1] * px[0];
  if ((u < 0 || v_ < 0 || w < 0) && (u > 0 || v_ > 0 || w > 0)) return false;
  const double det = u + v_ + w;
  if (det == 0.0) return false;
  *t = (u * pz[0] + v_ * pz[1] + w * pz[2]) / det;
  *bu = v_ / det;
  *bv = w / det;
  return true;
}

struct Best {
  double t = INFINITY;
  uint32_t instance = RF_INVALID, prim = RF_INVALID;
  bool closer(double t2, uint32_t i2, uint32_t p2) const {
    if (t2 != t) return t2 < t;
    if (i2 != instance) return i2 < instance;
    return p2 < prim;
  }
};

// Depth-first walk of one tree (either level): every leaf item whose boxes the
// ray enters before best.t goes to leaf(item); all_nodes skips the boxes.
template <class Leaf>
void walk_tree(const std::vector<rf_node>& nodes, uint32_t root, bool tlas, const Ray& r, const Best& best,
               bool all_nodes, Leaf leaf) {
  std::vector<uint32_t> stack{root};
  while (!stack.empty()) {
    const rf_node& n = nodes[stack.back()];
    stack.pop_back();
    if (!all_nodes && box_entry(n, r, best.t) == INFINITY) continue;
    const uint32_t count = tlas ? n.first >> RF_TLAS_COUNT_SHIFT : n.meta & RF_NODE_COUNT_MASK;
    const uint32_t first = tlas ? n.first & RF_TLAS_INDEX_MASK : n.first;
    if (count == 0) {
      stack.push_back(first);
      stack.push_back(first + 1);
      continue;
    }
    for (uint32_t k = 0; k < count; ++k) leaf(first + k);
  }
}

// A masked triangle's hit is kept by the masks' own rule (rf_alpha.h), at
// the double hit's barycentrics rounded to float.
void trace_blas(const std::vector<rf_node>& nodes, const PageAlignedVector<rf_tri>& tris, uint32_t root, const Ray& r,
                uint32_t instance, Best& best, bool all_nodes, const rf_alpha_tables* alpha) {
  walk_tree(nodes, root, false, r, best, all_nodes, [&](uint32_t i) {
    const rf_tri& tri = tris[i];
    double t, u, v;
    if (triangle(tri, r, &t, &u, &v) && t > 0.0 && best.closer(t, instance + tri.inst, tri.prim) &&
        (!alpha || rf_alpha_keeps(alpha, i, static_cast<float>(u), static_cast<float>(v)))) {
      best.t = t;
      best.instance = instance + tri.inst;
      best.prim = tri.prim;
    }
  });
}

}  // namespace

std::vector<ReferenceHit> trace_double_reference(const Scene& scene, const SceneData& data, const Camera& camera,
                                                 unsigned threads, bool brute_force) {
  // The frame's culled top-level items (padded float boxes, conservative for
  // double rays too) say which bottom-level subtrees a ray can meet; each is
  // entered with its instance's double tree_from_trace. Rays and t live in
  // the frame's trace space, as in the float tracers.
  const RayList rays = make_ray_list(camera.params, Fold::none);
  const Frame frame = build_frame(scene, data, camera, rays, FrameOptions{});
  std::vector<rf_node> nodes(data.blas.nodes.begin(), data.blas.nodes.end());
  nodes.insert(nodes.end(), frame.tlas_nodes.begin(), frame.tlas_nodes.end());
  std::vector<Xform> tree_from_trace(scene.instances.size());
  for (size_t i = 0; i < scene.instances.size(); ++i)
    tree_from_trace[i] = data.tree_from_world[i] * camera.world_from_camera * frame.views[0].camera_from_trace;

  const rf_alpha_tables tables = data.alpha.view();
  const rf_alpha_tables* alpha = data.alpha.empty() ? nullptr : &tables;
  const int w = camera.width, h = camera.height;
  std::vector<ReferenceHit> out(static_cast<size_t>(w) * h);
  parallel_for(static_cast<size_t>(h), threads, 1, [&](size_t row, size_t) {
    const int y = static_cast<int>(row);
    for (int x = 0; x < w; ++x) {
      const glm::dvec3 d = exact_direction(camera, x, y);  // exact, unlike the float rays
      const glm::dvec3 origin = exact_origin(camera, x, y) * std::ldexp(1.0, -frame.views[0].trace_exponent);
      const Ray cam_ray = make_ray(origin, d);
      Best best;
      if (brute_force) {
        for (size_t i = 0; i < scene.instances.size(); ++i) {
          // Each tree once: a merged one by its first member (bvh/blas.h).
          if (!data.renderable[i] || data.blas.instance_roots[i] == RF_INVALID) continue;
          const Xform& m = tree_from_trace[i];
          const Ray r = make_ray(glm::dvec3(m * glm::dvec4(origin, 1.0)), glm::dvec3(m * glm::dvec4(d, 0.0)));
          trace_blas(nodes, data.blas.tris, data.blas.instance_roots[i], r, static_cast<uint32_t>(i), best, true,
                     alpha);
        }
      } else if (frame.tlas_root != RF_INVALID) {
        walk_tree(nodes, frame.tlas_root, true, cam_ray, best, false, [&](uint32_t i) {
          const rf_instance& inst = frame.instances[i];
          const Xform& m = tree_from_trace[inst.instance_id];
          const Ray r = make_ray(glm::dvec3(m * glm::dvec4(origin, 1.0)), glm::dvec3(m * glm::dvec4(d, 0.0)));
          trace_blas(nodes, data.blas.tris, inst.blas_root, r, inst.instance_id, best, false, alpha);
        });
      }
      ReferenceHit& o = out[static_cast<size_t>(y) * w + x];
      if (best.instance != RF_INVALID) {
        o.distance = best.t * glm::length(d) * std::ldexp(1.0, frame.views[0].trace_exponent);
        o.instance = best.instance;
        o.primitive = best.prim;
      }
    }
  });
  return out;
}

}  // namespace rayfold::core
