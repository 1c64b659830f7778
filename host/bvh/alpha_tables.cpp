#include "bvh/alpha_tables.h"

#include <cmath>

#include "util/errors.h"

namespace rayfold::core {
namespace {

uint32_t wrap_code(int gl) {
  if (gl == 33071) return RF_WRAP_CLAMP;   // CLAMP_TO_EDGE
  if (gl == 33648) return RF_WRAP_MIRROR;  // MIRRORED_REPEAT
  return RF_WRAP_REPEAT;
}

// Calls visit(first, count) for every leaf of the binary tree at root.
template <class Visit>
void each_leaf(const BlasSet& blas, uint32_t root, Visit&& visit) {
  std::vector<uint32_t> stack{root};
  while (!stack.empty()) {
    const rf_node& n = blas.nodes[stack.back()];
    stack.pop_back();
    const uint32_t count = n.meta & RF_NODE_COUNT_MASK;
    if (count != 0) {
      visit(n.first, count);
    } else {
      stack.push_back(n.first);
      stack.push_back(n.first + 1);
    }
  }
}

}  // namespace

AlphaTables build_alpha_tables(const Scene& scene, const BlasSet& blas) {
  AlphaTables out;
  if (!has_alpha_masks(scene.meshes)) return out;
  // Per mesh, the record of each masked triangle (RF_INVALID: kept).
  std::vector<std::vector<uint32_t>> records(scene.meshes.size());
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    const Mesh& mesh = scene.meshes[m];
    if (mesh.alpha.empty()) continue;
    RF_CHECK_EQ(mesh.alpha.size(), mesh.triangle_count(), "a mesh's masks are per triangle");
    records[m].assign(mesh.alpha.size(), RF_INVALID);
    for (size_t k = 0; k < mesh.alpha.size(); ++k) {
      const AlphaTriangle& a = mesh.alpha[k];
      if (a.cutoff == -std::numeric_limits<float>::infinity()) continue;
      rf_alpha_tri t{};
      for (int c = 0; c < 3; ++c) {
        t.uv[2 * c] = a.uv[c].x;
        t.uv[2 * c + 1] = a.uv[c].y;
        t.alpha[c] = a.alpha[c];
      }
      t.cutoff = a.cutoff;
      t.image = a.image < 0 ? RF_INVALID : static_cast<uint32_t>(a.image);
      records[m][k] = static_cast<uint32_t>(out.tris.size());
      out.tris.push_back(t);
    }
  }
  if (out.tris.empty()) return out;
  for (const AlphaImage& im : scene.alpha_images) {
    RF_CHECK_EQ(im.alpha.size(), static_cast<size_t>(im.width) * im.height, "an alpha image's texels");
    if (out.texels.size() + im.alpha.size() > UINT32_MAX)
      throw InputError("",
                       "the alpha masks' textures hold more than 2^32 texels together, more than the trace "
                       "indexes");
    out.images.push_back({static_cast<uint32_t>(out.texels.size()), im.width, im.height,
                          wrap_code(im.wrap_s) | (wrap_code(im.wrap_t) << 2)});
    out.texels.insert(out.texels.end(), im.alpha.begin(), im.alpha.end());
  }
  // Device buffers of at least one element (a mask of factors alone reads neither).
  if (out.images.empty()) out.images.push_back({0, 1, 1, 0});
  if (out.texels.empty()) out.texels.push_back(0);
  // Each tree's triangles: a mesh's own tree, or a merged group's, whose
  // triangle's member is its first instance plus rf_tri::inst.
  out.index.assign(blas.tris.size(), RF_INVALID);
  for (size_t m = 0; m < scene.meshes.size(); ++m) {
    if (records[m].empty() || blas.roots[m] == RF_INVALID) continue;
    each_leaf(blas, blas.roots[m], [&](uint32_t first, uint32_t count) {
      for (uint32_t ti = first; ti < first + count; ++ti) out.index[ti] = records[m][blas.tris[ti].prim];
    });
  }
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    if (!blas.merged[i] || blas.traced_by[i] != i || blas.instance_roots[i] == RF_INVALID) continue;
    each_leaf(blas, blas.instance_roots[i], [&](uint32_t first, uint32_t count) {
      for (uint32_t ti = first; ti < first + count; ++ti) {
        const uint32_t mesh = scene.instances[i + blas.tris[ti].inst].mesh;
        if (!records[mesh].empty()) out.index[ti] = records[mesh][blas.tris[ti].prim];
      }
    });
  }
  return out;
}

}  // namespace rayfold::core
