// Rays from anywhere (Renderer::intersect, scene.intersect): the caller's
// world-space rays, checked, taken into the trace space of a view from the
// world's origin (world space in units of a power of two, so t along each
// ray is unchanged), and the frame they are traced through: every
// renderable instance, none culled, one transform group.
#pragma once

#include <cstddef>
#include <vector>

#include "fold/frame.h"
#include "reference/trace_inputs.h"

namespace rayfold::core {

// The rays of one query: origins and directions n x 3 (row-major), a hit
// counting when tmin < t <= tmax. InputError naming the first bad ray: a
// coordinate not finite, a zero direction, or an origin beyond world
// coordinates of 2^126; or tmin, tmax not 0 <= tmin <= tmax (tmax may be
// +inf).
void check_query_rays(const float* origins, const float* directions, size_t n, float tmin, float tmax);

// The camera whose trace space queries use: at the world's origin, looking
// down -z, so that its trace space is world space scaled by 2^-e.
Camera query_camera();

// The frame for these rays (its options' fold, cull and query_origin_bound
// are set here; moved and normals are the caller's).
Frame build_query_frame(const Scene& scene, const SceneData& data, const float* origins, size_t n,
                        FrameOptions options);

// Rays [begin, end) in trace space.
void to_trace_space(const float* origins, const float* directions, size_t begin, size_t end, float tmin, float tmax,
                    const Frame& frame, std::vector<rf_query_ray>& out);

// Tiles of consecutive rays with the same origin (bit for bit), at most
// RF_TILE_RAYS each, as a table of first rays ending in rays.size(): what
// the query tile kernel traces. Empty when they would average fewer than
// min_rays rays a tile (rays from many origins: the single-ray kernel).
std::vector<uint32_t> shared_origin_tiles(const std::vector<rf_query_ray>& rays, size_t min_rays);

// The CPU reference's answers, one rf_pixel_hit per ray (z = t).
void trace_queries_cpu(const TraceInputs& in, const std::vector<rf_query_ray>& rays, bool any_hit, unsigned write_flags,
                       rf_pixel_hit* out, unsigned threads);

}  // namespace rayfold::core
