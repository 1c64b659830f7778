// What a scene needs once, whatever the view: the bottom-level trees in their
// tree spaces, the instances' transforms and normal matrices, and the cut
// through each tree that enters the top level (partial re-braiding). The
// per-frame work over it is fold/frame.h.
#pragma once

#include <climits>
#include <cstdint>
#include <vector>

#include "bvh/alpha_tables.h"
#include "bvh/blas.h"
#include "device_layout.h"
#include "scene/scene.h"
#include "util/page_aligned.h"

namespace rayfold::core {

// Partial re-braiding (Benthin, Wald, Woop, Afra 2017): the top-level tree
// is built not over whole instances but over a cut through each traced
// instance's bottom-level tree, opened largest-first in world space, so
// that instances whose trees overlap meet as their parts, where near-to-far
// order stops rays early and culling (per fold group) drops the parts a
// quadrant cannot see.
//
// Meshes grouped by material, which overlap the whole scene, needed much
// of it (min_items and loose_ratio below: Lost Empire 2x, the Dabrovic
// Sponza 1.4x). Since such meshes share one merged tree (bvh/blas.h), the
// tile kernel traces that tree's upper levels faster in its own 4-wide
// nodes than as top-level items: on random views (docs/results.md) the
// budget alone traced Sponza and the conference room 1.28x faster than with
// the minimum and the loose rule, the car 1.16x, Lost Empire and the
// armadillo 1.1x, the atrium (240 instances of their own transforms) 1.08x.
struct BraidOptions {
  bool enabled = true;
  size_t items_per_instance = 2;    // budget: this many items per traced instance on average...
  size_t min_items = 0;             // ...but at least this many
  double min_area_fraction = 1e-3;  // never open a node smaller than this share of the scene
  // Past the budget, a node still opens when its children's world boxes
  // together have less than loose_ratio times its surface: its triangles lie
  // apart and its box is mostly empty space, the space where the boxes of a
  // building's per-material meshes overlap when they are not merged (1.0,
  // with min_items 256, was the default before merged trees).
  double loose_ratio = 0.0;
};

struct SceneData {
  BlasSet blas;
  // The cut of each instance's tree: braid_nodes[braid_offsets[i] ..
  // braid_offsets[i + 1]) are the BLAS nodes that enter the top level for
  // instance i (just its root when re-braiding is off; none for a merged
  // instance other than its group's first, blas.traced_by).
  std::vector<uint32_t> braid_offsets;
  std::vector<uint32_t> braid_nodes;
  // The tile kernel's wide trees below the braid nodes (bvh/wide_bvh.h);
  // braid_wide[c] is braid_nodes[c]'s wide node (RF_INVALID for a leaf).
  PageAlignedVector<rf_wide_node> wide_nodes;
  std::vector<uint32_t> braid_wide;
  std::vector<Xform> tree_from_world;          // per scene instance, into its mesh's tree space
  std::vector<bool> renderable;                // false: singular transform or empty mesh
  std::vector<rf_normal_xform> normal_xforms;  // per scene instance, tree-space normals to world
  Aabb world_bounds;                           // of the renderable instances at rest
  // The largest ilogb of a tree_from_world linear entry over the renderable
  // instances: how many tree units the smallest instance packs into a world
  // unit, as a power of two (frame.h's trace exponent keeps it in range).
  int max_tree_scale = INT_MIN;
  size_t hidden_instances = 0;
  AlphaTables alpha;  // the masked triangles' tables (empty for a scene without masks)
};

SceneData prepare_scene(const Scene& scene, unsigned threads = 0, const BraidOptions& braid = {},
                        const MergeOptions& merge = {});

// The most top-level items (instances and their copies per view and mirror)
// and nodes a frame of this scene with `groups` transform groups can need;
// device buffers are sized by them.
size_t max_tlas_items(const SceneData& data, int groups = RF_MIRRORS);
size_t max_tlas_nodes(const SceneData& data, int groups = RF_MIRRORS);

}  // namespace rayfold::core
