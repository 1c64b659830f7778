// The alpha masks as the trace reads them (rf_alpha.h, rf_types.h's
// rf_alpha_tri and rf_alpha_image): a record per masked triangle, indexed
// by the triangle's place in the trees' triangle array, so that a hit finds
// its mask whatever tree (a mesh's own, a merged group's) holds it.
#pragma once

#include <cstdint>
#include <vector>

#include "bvh/blas.h"
#include "device_layout.h"
#include "rf_alpha.h"
#include "scene/scene.h"

namespace rayfold::core {

struct AlphaTables {
  std::vector<uint32_t> index;  // per BlasSet triangle: its record in `tris`, RF_INVALID: always kept
  std::vector<rf_alpha_tri> tris;
  std::vector<rf_alpha_image> images;
  std::vector<uint8_t> texels;
  bool empty() const { return tris.empty(); }
  // Views for the CPU trace; all null when empty.
  rf_alpha_tables view() const {
    if (empty()) return rf_alpha_tables{nullptr, nullptr, nullptr, nullptr};
    return rf_alpha_tables{index.data(), tris.data(), images.data(), texels.data()};
  }
};

// The tables of a scene's masked triangles (Mesh::alpha) over the trees of
// `blas`; empty when no mesh has a masked triangle.
AlphaTables build_alpha_tables(const Scene& scene, const BlasSet& blas);

}  // namespace rayfold::core
