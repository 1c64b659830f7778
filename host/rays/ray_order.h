// The order scattered rays are traced in (rays from many origins: a
// lidar's sweep from a moving platform, sample points' visibility rays):
// by the cell of a 16^3 grid over their origins' box that holds each
// origin, in Morton order, and within a cell by the octant of the
// direction. Neighbouring work-items then walk neighbouring parts of the
// trees (docs/results.md, "Rays from anywhere: scattered rays in order").
// Every ray is traced alone, so its answer does not depend on the order.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace rayfold::core {

// Rays below this count keep the input order: sorting costs more than it
// saves.
constexpr size_t kMinOrderedRays = 1024;

// The key rays are ordered by, given the origins' box (lo, hi): the Morton
// code of the origin's cell, then the octant (bit a: the direction's
// component a has its sign bit set).
uint32_t scattered_ray_key(const float* origin, const float* direction, const float lo[3], const float hi[3]);

// order[k]: the input index of the k-th ray to trace, by key, ties in input
// order (so the same order on any thread count); empty (the input order)
// below kMinOrderedRays. Origins and directions n x 3, finite
// (check_query_rays).
void scattered_ray_order(const float* origins, const float* directions, size_t n, std::vector<uint32_t>& order,
                         unsigned threads);

}  // namespace rayfold::core
