// Rays from anywhere (Pipeline::intersect, scene.intersect): the caller's
// world-space rays, checked, taken into the trace space of a view from the
// world's origin (world space in units of a power of two, so t along each
// ray is unchanged), and the frame they are traced through: every
// renderable instance, none culled, one transform group.
#pragma once

#include <cstddef>
#include <optional>
#include <vector>

#include "bvh/wide_bvh.h"
#include "fold/frame.h"
#include "reference/trace_inputs.h"

namespace rayfold::core {

// The rays of one query: origins and directions n x 3 (row-major), a hit
// counting when tmin < t <= tmax. InputError naming the first bad ray: a
// coordinate not finite, a zero direction, or an origin beyond world
// coordinates of 2^126; or tmin, tmax not 0 <= tmin <= tmax (tmax may be
// +inf).
// Returns the largest |coordinate| of any origin; *one_origin (unless null):
// whether every ray has ray 0's origin, bit for bit.
float check_query_rays(const float* origins, const float* directions, size_t n, float tmin, float tmax,
                       bool* one_origin = nullptr);

// The camera whose trace space queries use: at the world's origin, looking
// down -z, so that its trace space is world space scaled by 2^-e.
Camera query_camera();

// The frame for rays whose origins lie within origin_bound of the world's
// origin in every coordinate (check_query_rays' answer); its options'
// fold, cull and query_origin_bound are set here, moved and normals are
// the caller's.
// query_trees: the bottom levels as 8-wide trees (build_query_trees), whose
// roots the frame's query_wide_roots name; null leaves them empty (a frame
// for the CPU reference or the tile kernel).
Frame build_query_frame(const Scene& scene, const SceneData& data, float origin_bound, FrameOptions options,
                        const Wide8Trees* query_trees = nullptr);

// The bottom levels as 8-wide trees for the single-ray query kernel, each
// instance's whole tree (BlasSet::instance_roots) collapsed from its root;
// roots per scene instance (RF_INVALID: none, or a leaf).
Wide8Trees build_query_trees(const SceneData& data);

// Rays [begin, end) in trace space, as the single-ray kernel and the CPU
// reference read them: in the order they are traced, out[k] ray begin +
// order[k] (empty: the input order).
void to_trace_space(const float* origins, const float* directions, size_t begin, size_t end, float tmin, float tmax,
                    const Frame& frame, std::vector<rf_query_ray>& out, const std::vector<uint32_t>& order = {});

// How the query tile kernel traces a batch of rays: tiles of rays with the
// same origin (bit for bit), at most RF_TILE_RAYS each, as a table of first
// rays ending in the ray count, in the order `order` gives (order[k]: the
// input index of the k-th ray traced; empty: the input order). Rays that
// are an image's, rows of row_length, go in RF_TILE_SIDE-square blocks (a
// row of 256 pixels per tile made dense views 1.6x slower).
struct QueryTiles {
  std::vector<uint32_t> tiles;  // empty: too few rays a tile on average (min_rays), trace them one by one
  std::vector<uint32_t> order;
  // The order the rays are traced in: `order` with tiles, the input order
  // without (the single-ray kernel then takes them in `scattered`'s order).
  const std::vector<uint32_t>& traced_order() const;
  // Without tiles, the order the single-ray kernel takes the rays in
  // (rays/ray_order.h; empty: the input order): to_trace_space writes the
  // records in it, and the answers are put back in the input order.
  std::vector<uint32_t> scattered;
  // The image order `order` holds (rows x row_length, 0: none) and its
  // tiles' first rays, kept for the next plan of the same size; the size
  // before it is kept aside too (an image's chunks are whole bands, its
  // last one often shorter).
  size_t image_rows = 0, image_row_length = 0;
  std::vector<uint32_t> image_tiles;
  size_t spare_rows = 0, spare_row_length = 0;
  std::vector<uint32_t> spare_order, spare_tiles;
};
QueryTiles plan_query_tiles(const float* origins, size_t n, size_t row_length, size_t min_rays);
// The same into `plan`, reusing the image order it holds when the image
// size is the one it was made for (3 ms a 720p query otherwise).
// same_origin: whether every ray has ray 0's origin where the caller knows
// (check_query_rays), else looked at here.
void plan_query_tiles(const float* origins, size_t n, size_t row_length, size_t min_rays, QueryTiles& plan,
                      std::optional<bool> same_origin = std::nullopt);
// Rays per chunk of a query (memory stays bounded): 2^20, in whole bands
// of RF_TILE_SIDE rows of row_length where that is given.
size_t query_chunk_rays(size_t row_length);

// The CPU reference's answers, one rf_pixel_hit per ray (z = t): rays[k]
// (to_trace_space's, in `order`) answers out[order[k]] (out[k] without an
// order).
void trace_queries_cpu(const TraceInputs& in, const std::vector<rf_query_ray>& rays, bool any_hit, unsigned write_flags,
                       rf_pixel_hit* out, unsigned threads, const std::vector<uint32_t>& order = {});

}  // namespace rayfold::core
