#include "rays/ray_queries.h"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <cstring>
#include <string>

#include "bvh/wide_bvh.h"
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

float check_query_rays(const float* origins, const float* directions, size_t n, float tmin, float tmax,
                       bool* one_origin) {
  if (!(tmin >= 0.0f) || !std::isfinite(tmin) || !(tmax >= tmin))
    throw InputError("", "tmin and tmax must satisfy 0 <= tmin <= tmax (tmax may be inf), not tmin " +
                             std::to_string(tmin) + ", tmax " + std::to_string(tmax));
  // One pass over the bits, which vectorises (a million rays in about a
  // millisecond where the float tests took 5): a non-negative float's
  // order is its bits' order, inf and NaN lie above every finite value,
  // and the largest origin coordinate comes out with it. Only a batch with
  // a bad ray is scanned again for the first.
  static_assert(sizeof(float) == sizeof(uint32_t), "floats of 32 bits");
  constexpr uint32_t kAbs = 0x7FFFFFFFu, kInf = 0x7F800000u;
  uint32_t limit_bits;
  const float limit = static_cast<float>(kMaxWorldCoordinate);
  std::memcpy(&limit_bits, &limit, sizeof limit);
  uint32_t bad = 0, largest = 0, moved = 0;
  const auto word = [](const float* p, size_t i) {
    uint32_t w;
    std::memcpy(&w, p + i, sizeof w);
    return w;
  };
  const auto bits = [&](const float* p, size_t i) { return word(p, i) & kAbs; };
  uint32_t first[3] = {0, 0, 0};
  if (n != 0)
    for (int k = 0; k < 3; ++k) first[k] = word(origins, k);
  // On both threads, in chunks of whole rays. Whether every origin is ray
  // 0's comes with the pass (the renderer hands it to plan_query_tiles,
  // whose own pass over the origins, on one thread, was 4% of a camera's
  // rays as arrays).
  constexpr size_t kChunk = size_t{1} << 16;
  std::vector<uint32_t> chunk_bad((n + kChunk - 1) / kChunk), chunk_largest(chunk_bad.size()),
      chunk_moved(chunk_bad.size());
  parallel_for(n, 0, kChunk, [&](size_t lo, size_t hi) {
    uint32_t b = 0, l = 0, m = 0;
    for (size_t i = 3 * lo; i < 3 * hi; ++i) {  // flat over the coordinates: this loop vectorises
      const uint32_t ao = bits(origins, i), ad = bits(directions, i);
      l = std::max(l, ao);
      b |= static_cast<uint32_t>(ao > limit_bits) | static_cast<uint32_t>(ad >= kInf);
    }
    for (size_t i = lo; i < hi; ++i) {
      b |= static_cast<uint32_t>(
          (bits(directions, 3 * i) | bits(directions, 3 * i + 1) | bits(directions, 3 * i + 2)) == 0);
      m |= (word(origins, 3 * i) ^ first[0]) | (word(origins, 3 * i + 1) ^ first[1]) |
           (word(origins, 3 * i + 2) ^ first[2]);
    }
    chunk_bad[lo / kChunk] = b;
    chunk_largest[lo / kChunk] = l;
    chunk_moved[lo / kChunk] = m;
  });
  for (size_t c = 0; c < chunk_bad.size(); ++c) {
    bad |= chunk_bad[c];
    largest = std::max(largest, chunk_largest[c]);
    moved |= chunk_moved[c];
  }
  if (one_origin) *one_origin = moved == 0;
  if (bad == 0) {
    float out;
    std::memcpy(&out, &largest, sizeof out);
    return out;
  }
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
  RF_CHECK(false, "the bit test saw a bad ray the scan did not find");
  return 0.0f;
}

Camera query_camera() {
  CameraSpec spec;  // eye 0, looking at (0, 0, -1), up y: world_from_camera is the identity
  return make_camera(spec, 1, 1);
}

Wide8Trees build_query_trees(const SceneData& data) {
  std::vector<uint32_t> entries;
  for (uint32_t root : data.blas.instance_roots)
    if (root != RF_INVALID) entries.push_back(root);
  Wide8Trees trees = build_wide8_trees(data.blas.nodes.data(), data.blas.nodes.size(), entries);
  std::vector<uint32_t> per_instance(data.blas.instance_roots.size(), RF_INVALID);
  for (size_t i = 0, e = 0; i < per_instance.size(); ++i)
    if (data.blas.instance_roots[i] != RF_INVALID) per_instance[i] = trees.roots[e++];
  trees.roots = std::move(per_instance);
  return trees;
}

Frame build_query_frame(const Scene& scene, const SceneData& data, float origin_bound, FrameOptions options,
                        const Wide8Trees* query_trees) {
  const Camera camera = query_camera();
  const int e = trace_exponent(data, camera);
  const double bound = origin_bound;
  options.fold = Fold::none;
  options.cull = false;
  options.planar_depth = false;
  options.query_origin_bound = std::ldexp(bound, -e);
  options.whole_trees = query_trees != nullptr;
  Frame frame = build_frame(scene, data, camera, make_ray_list(camera.params, Fold::none), options);
  frame.query = true;
  if (query_trees && frame.tlas_root != RF_INVALID) {
    // rf_trace_query_tlas_wide answers group 0 alone, which a frame of one
    // view and no mirrors is.
    for (const rf_instance& inst : frame.instances) RF_CHECK_EQ(inst.group, 0u, "a query frame with mirrored copies");
    Wide8Trees wide = build_wide8_tlas(frame.tlas_nodes, frame.node_base, frame.tlas_root);
    frame.tlas_wide = std::move(wide.nodes);
    frame.tlas_wide_root = wide.roots[0];
  }
  if (query_trees) {
    RF_CHECK_EQ(query_trees->roots.size(), data.blas.instance_roots.size(), "query trees of another scene");
    frame.query_wide_roots.reserve(frame.instances.size());
    for (const rf_instance& inst : frame.instances) frame.query_wide_roots.push_back(query_trees->roots[inst.instance_id]);
  }
  return frame;
}

void to_trace_space(const float* origins, const float* directions, size_t begin, size_t end, float tmin, float tmax,
                    const Frame& frame, std::vector<rf_query_ray>& out, const std::vector<uint32_t>& order) {
  RF_CHECK(order.empty() || order.size() == end - begin, "query order of another length");
  // Origin and direction scaled alike keep t; a power of two is exact
  // while the result stays a normal float. The query tile kernel scales
  // its rays the same way (rf_tile.h, rf_pow2_scale).
  const Pow2Scale trace_from_world(-frame.views.at(0).trace_exponent);
  out.resize(end - begin);
  constexpr size_t kAhead = 16;
  parallel_for(end - begin, 0, size_t{1} << 16, [&](size_t lo, size_t hi) {
    for (size_t k = lo; k < hi; ++k) {
      rf_query_ray& q = out[k];
      const size_t i = begin + (order.empty() ? k : order[k]);
      // In an order the reads are scattered: each is a cache miss, fetched
      // a few rays ahead.
      if (!order.empty() && k + kAhead < hi) {
        __builtin_prefetch(&origins[3 * (begin + order[k + kAhead])]);
        __builtin_prefetch(&directions[3 * (begin + order[k + kAhead])]);
      }
      for (int c = 0; c < 3; ++c) {
        q.o[c] = trace_from_world(origins[3 * i + c]);
        q.d[c] = trace_from_world(directions[3 * i + c]);
      }
      q.tmin = tmin;
      q.tmax = tmax;
    }
  });
}

size_t query_chunk_rays(size_t row_length) {
  // 64 MiB of rays and answers. Image chunks of 2^17 and 2^18 rays kept
  // their rays and answers in the cache between the host and the tile
  // kernel (5% to 8% less CPU time on a 720p car view) but left a thread
  // idle at the end of each launch, and took as long.
  constexpr size_t kChunk = size_t{1} << 20;
  const size_t band = RF_TILE_SIDE * row_length;
  return row_length >= RF_TILE_SIDE && band <= kChunk ? kChunk / band * band : kChunk;
}

namespace {

// An image's rays in the order of a camera's ray list (fold/ray_list.cpp):
// RF_TILE_SIDE-square tiles of 8x8 blocks of 4x4 quads, each quad row by
// row, so that a vector's 16 rays are a 4x4 quad; the first ray of each
// tile into tile_starts.
std::vector<uint32_t> image_order(size_t rows, size_t row_length, std::vector<uint32_t>& tile_starts) {
  constexpr size_t kBlock = 8, kQuad = 4;
  std::vector<uint32_t> order;
  order.reserve(rows * row_length);
  const auto tile = [&](size_t ty, size_t tx, size_t stride, size_t height, size_t width) {
    for (size_t by = ty; by < std::min(ty + RF_TILE_SIDE, height); by += kBlock)
      for (size_t bx = tx; bx < std::min(tx + RF_TILE_SIDE, width); bx += kBlock)
        for (size_t qy = by; qy < std::min(by + kBlock, height); qy += kQuad)
          for (size_t qx = bx; qx < std::min(bx + kBlock, width); qx += kQuad)
            for (size_t y = qy; y < std::min(qy + kQuad, height); ++y)
              for (size_t x = qx; x < std::min(qx + kQuad, width); ++x)
                order.push_back(static_cast<uint32_t>(y * stride + x));
  };
  // A whole tile's offsets once; edge tiles the long way.
  tile(0, 0, row_length, RF_TILE_SIDE, RF_TILE_SIDE);
  const std::vector<uint32_t> whole(order.begin(), order.end());
  order.clear();
  for (size_t ty = 0; ty < rows; ty += RF_TILE_SIDE)
    for (size_t tx = 0; tx < row_length; tx += RF_TILE_SIDE) {
      tile_starts.push_back(static_cast<uint32_t>(order.size()));
      if (ty + RF_TILE_SIDE <= rows && tx + RF_TILE_SIDE <= row_length) {
        const uint32_t base = static_cast<uint32_t>(ty * row_length + tx);
        for (uint32_t o : whole) order.push_back(base + o);
      } else {
        tile(ty, tx, row_length, rows, row_length);
      }
    }
  return order;
}

// Whether every ray has ray 0's origin, bit for bit (one pass that
// vectorises).
bool one_origin(const float* origins, size_t n) {
  uint32_t first[3], diff = 0;
  std::memcpy(first, origins, sizeof first);
  for (size_t i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) {
      uint32_t w;
      std::memcpy(&w, origins + 3 * i + k, sizeof w);
      diff |= w ^ first[k];
    }
  return diff == 0;
}

}  // namespace

void plan_query_tiles(const float* origins, size_t n, size_t row_length, size_t min_rays, QueryTiles& plan,
                      std::optional<bool> same_origin) {
  plan.tiles.clear();
  if (n == 0) return;
  // An image's rays in RF_TILE_SIDE-square tiles; the order is kept for the
  // next query of the same image size (a camera's every frame).
  const bool blocks = row_length >= RF_TILE_SIDE && n % row_length == 0;
  if (!blocks) {
    plan.order.clear();
    plan.image_rows = plan.image_row_length = 0;
  } else if (plan.image_rows != n / row_length || plan.image_row_length != row_length) {
    std::swap(plan.order, plan.spare_order);
    std::swap(plan.image_tiles, plan.spare_tiles);
    std::swap(plan.image_rows, plan.spare_rows);
    std::swap(plan.image_row_length, plan.spare_row_length);
    if (plan.image_rows != n / row_length || plan.image_row_length != row_length) {
      plan.image_tiles.clear();
      plan.order = image_order(n / row_length, row_length, plan.image_tiles);
      plan.image_rows = n / row_length;
      plan.image_row_length = row_length;
    }
  }
  const std::vector<uint32_t>& block_starts = plan.image_tiles;
  if (blocks && (same_origin ? *same_origin : one_origin(origins, n))) {  // a camera's: the blocks are the tiles
    plan.tiles = block_starts;
    plan.tiles.push_back(static_cast<uint32_t>(n));
    return;
  }
  const auto ray = [&](size_t k) { return origins + 3 * (blocks ? plan.order[k] : k); };
  plan.tiles.push_back(0);
  size_t next_block = 1;
  for (size_t k = 1; k < n; ++k) {
    const bool block_start = blocks && next_block < block_starts.size() && block_starts[next_block] == k;
    next_block += block_start;
    if (!block_start && k - plan.tiles.back() < RF_TILE_RAYS && std::memcmp(ray(k), ray(k - 1), 3 * sizeof(float)) == 0)
      continue;
    plan.tiles.push_back(static_cast<uint32_t>(k));
    // Give up early on rays from many origins.
    if (plan.tiles.size() > 64 && plan.tiles.size() * min_rays > 2 * k) {
      plan.tiles.clear();
      return;
    }
  }
  plan.tiles.push_back(static_cast<uint32_t>(n));
  if ((plan.tiles.size() - 1) * min_rays > n) plan.tiles.clear();
}

QueryTiles plan_query_tiles(const float* origins, size_t n, size_t row_length, size_t min_rays) {
  QueryTiles plan;
  plan_query_tiles(origins, n, row_length, min_rays, plan);
  if (plan.tiles.empty()) plan.order.clear();
  return plan;
}

const std::vector<uint32_t>& QueryTiles::traced_order() const {
  static const std::vector<uint32_t> input_order;
  return tiles.empty() ? input_order : order;
}

void trace_queries_cpu(const TraceInputs& in, const std::vector<rf_query_ray>& rays, bool any_hit, unsigned write_flags,
                       rf_pixel_hit* out, unsigned threads, const std::vector<uint32_t>& order) {
  RF_CHECK(order.empty() || order.size() == rays.size(), "query order of another length");
  parallel_for(rays.size(), threads, 256, [&](size_t begin, size_t end) {
    for (size_t k = begin; k < end; ++k) {
      const size_t i = order.empty() ? k : order[k];
      rf_trace_query(&rays[k], in.nodes, nullptr, nullptr, RF_INVALID, nullptr, in.tris, in.instances, in.normal_xforms,
                     in.tlas_root, any_hit ? 1 : 0, write_flags, &out[i], in.alpha_tables());
    }
  });
}

}  // namespace rayfold::core
