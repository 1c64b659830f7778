#include "rays/ray_queries.h"

#include <algorithm>
#include <cfloat>
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
  // A branch-free pass first (it vectorises: a million rays in a few ms);
  // only a batch with a bad ray is scanned again for the first.
  const float limit = static_cast<float>(kMaxWorldCoordinate);
  bool all_good = true;
  for (size_t i = 0; i < n; ++i) {
    const float* o = origins + 3 * i;
    const float* d = directions + 3 * i;
    bool good = (d[0] != 0.0f) | (d[1] != 0.0f) | (d[2] != 0.0f);
    for (int k = 0; k < 3; ++k) good &= (std::fabs(o[k]) <= limit) & (std::fabs(d[k]) <= FLT_MAX);
    all_good &= good;
  }
  if (all_good) return;
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
                    const Frame& frame, std::vector<rf_query_ray>& out, const std::vector<uint32_t>& order) {
  RF_CHECK(order.empty() || order.size() == end - begin, "ray order of another length");
  // Origin and direction scaled alike keep t; a power of two is exact
  // while the result stays a normal float.
  const Pow2Scale trace_from_world(-frame.views.at(0).trace_exponent);
  out.resize(end - begin);
  parallel_for(end - begin, 0, size_t{1} << 16, [&](size_t lo, size_t hi) {
    for (size_t k = lo; k < hi; ++k) {
      rf_query_ray& q = out[k];
      const size_t i = begin + (order.empty() ? k : order[k]);
      for (int k = 0; k < 3; ++k) {
        q.o[k] = trace_from_world(origins[3 * i + k]);
        q.d[k] = trace_from_world(directions[3 * i + k]);
      }
      q.tmin = tmin;
      q.tmax = tmax;
    }
  });
}

size_t query_chunk_rays(size_t row_length) {
  constexpr size_t kChunk = size_t{1} << 20;  // 64 MiB of rays and answers
  const size_t band = RF_TILE_SIDE * row_length;
  return row_length >= RF_TILE_SIDE && band <= kChunk ? kChunk / band * band : kChunk;
}

QueryTiles plan_query_tiles(const float* origins, size_t n, size_t row_length, size_t min_rays) {
  QueryTiles plan;
  if (n == 0) return plan;
  // An image's rays in blocks of RF_TILE_SIDE x RF_TILE_SIDE, each a tile.
  const bool blocks = row_length >= RF_TILE_SIDE && n % row_length == 0;
  std::vector<uint32_t> block_starts;
  if (blocks) {
    plan.order.reserve(n);
    const size_t rows = n / row_length;
    for (size_t by = 0; by < rows; by += RF_TILE_SIDE)
      for (size_t bx = 0; bx < row_length; bx += RF_TILE_SIDE) {
        block_starts.push_back(static_cast<uint32_t>(plan.order.size()));
        for (size_t y = by; y < std::min(by + RF_TILE_SIDE, rows); ++y)
          for (size_t x = bx; x < std::min(bx + RF_TILE_SIDE, row_length); ++x)
            plan.order.push_back(static_cast<uint32_t>(y * row_length + x));
      }
  }
  const auto ray = [&](size_t k) { return origins + 3 * (blocks ? plan.order[k] : k); };
  plan.tiles.push_back(0);
  size_t next_block = 1;
  for (size_t k = 1; k < n; ++k) {
    const bool block_start = next_block < block_starts.size() && block_starts[next_block] == k;
    next_block += block_start;
    if (!block_start && k - plan.tiles.back() < RF_TILE_RAYS && std::memcmp(ray(k), ray(k - 1), 3 * sizeof(float)) == 0)
      continue;
    plan.tiles.push_back(static_cast<uint32_t>(k));
    // Give up early on rays from many origins.
    if (plan.tiles.size() > 64 && plan.tiles.size() * min_rays > 2 * k) return {};
  }
  plan.tiles.push_back(static_cast<uint32_t>(n));
  if ((plan.tiles.size() - 1) * min_rays > n) return {};
  return plan;
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
