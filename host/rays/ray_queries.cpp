#include "rays/ray_queries.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "fold/ray_list.h"
#include "rf_trace.h"
#include "util/errors.h"
#include "util/parallel.h"
#include "util/pow2.h"

namespace rayfold::core {
namespace {

std::string ray_text(const char* what, size_t i, const float* v) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "ray %zu: %s (%g, %g, %g)", i, what, v[0], v[1], v[2]);
  return buf;
}

}  // namespace

void check_query_rays(const float* origins, const float* directions, size_t n, float tmin, float tmax) {
  if (!(tmin >= 0.0f) || !std::isfinite(tmin) || !(tmax >= tmin))
    throw InputError("", "tmin and tmax must satisfy 0 <= tmin <= tmax (tmax may be inf), not tmin " +
                             std::to_string(tmin) + ", tmax " + std::to_string(tmax));
  for (size_t i = 0; i < n; ++i) {
    const float* o = origins + 3 * i;
    const float* d = directions + 3 * i;
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(o[k])) throw InputError("", ray_text("origin is not finite", i, o));
      if (std::fabs(o[k]) > static_cast<float>(kMaxWorldCoordinate))
        throw InputError("", ray_text("origin lies beyond world coordinates of 2^126", i, o));
      if (!std::isfinite(d[k])) throw InputError("", ray_text("direction is not finite", i, d));
    }
    if (d[0] == 0.0f && d[1] == 0.0f && d[2] == 0.0f) throw InputError("", ray_text("direction is zero", i, d));
  }
}

Camera query_camera() {
  CameraSpec spec;  // eye 0, looking at (0, 0, -1), up y: world_from_camera is the identity
  return make_camera(spec, 1, 1);
}

Frame build_query_frame(const Scene& scene, const SceneData& data, const float* origins, size_t n,
                        FrameOptions options) {
  const Camera camera = query_camera();
  const int e = trace_exponent(data, camera);
  double bound = 0.0;
  for (size_t i = 0; i < 3 * n; ++i) bound = std::max(bound, std::fabs(static_cast<double>(origins[i])));
  options.fold = FoldMode::none;
  options.cull = false;
  options.planar_depth = false;
  options.query_origin_bound = std::ldexp(bound, -e);
  return build_frame(scene, data, camera, make_ray_list(camera.params, FoldMode::none), options);
}

void to_trace_space(const float* origins, const float* directions, size_t begin, size_t end, float tmin, float tmax,
                    const Frame& frame, std::vector<rf_query_ray>& out) {
  // Origin and direction scaled alike keep t; a power of two is exact
  // while the result stays a normal float.
  const Pow2Scale trace_from_world(-frame.views.at(0).trace_exponent);
  out.resize(end - begin);
  for (size_t i = begin; i < end; ++i) {
    rf_query_ray& q = out[i - begin];
    for (int k = 0; k < 3; ++k) {
      q.o[k] = trace_from_world(origins[3 * i + k]);
      q.d[k] = trace_from_world(directions[3 * i + k]);
    }
    q.tmin = tmin;
    q.tmax = tmax;
  }
}

std::vector<uint32_t> shared_origin_tiles(const std::vector<rf_query_ray>& rays, size_t min_rays) {
  std::vector<uint32_t> tiles;
  if (rays.empty()) return tiles;
  tiles.push_back(0);
  for (size_t i = 1; i < rays.size(); ++i) {
    const bool same = std::memcmp(rays[i].o, rays[i - 1].o, sizeof rays[i].o) == 0;
    if (!same || i - tiles.back() == RF_TILE_RAYS) {
      tiles.push_back(static_cast<uint32_t>(i));
      // Give up early on rays from many origins.
      if (tiles.size() > 64 && tiles.size() * min_rays > 2 * i) return {};
    }
  }
  tiles.push_back(static_cast<uint32_t>(rays.size()));
  if ((tiles.size() - 1) * min_rays > rays.size()) return {};
  return tiles;
}

void trace_queries_cpu(const TraceInputs& in, const std::vector<rf_query_ray>& rays, bool any_hit, unsigned write_flags,
                       rf_pixel_hit* out, unsigned threads) {
  parallel_for(rays.size(), threads, 256, [&](size_t begin, size_t end) {
    for (size_t i = begin; i < end; ++i)
      rf_trace_query(&rays[i], in.nodes, in.tris, in.instances, in.normal_xforms, in.tlas_root, any_hit ? 1 : 0,
                     write_flags, &out[i]);
  });
}

}  // namespace rayfold::core
