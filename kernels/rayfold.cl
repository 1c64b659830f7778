/* rayfold.cl - device entry points. The host prepends the shared headers
 * (rf_common.h, rf_types.h, rf_geometry.h, rf_trace.h) and the device-only
 * rf_lanes.h and rf_tile.h (host/opencl/kernel_sources.h), so this file holds only
 * the entry points. */

/* The camera and pass (rf_camera) as kernel arguments, field by field, then
 * one depth scale per view of the pass. */
#define RF_CAMERA_ARGS                                                                                            \
  float scale_x, float scale_y, int kx0, int ky0, int width, int height, int xpair, int ypair, float frac_x,      \
      float frac_y, int ortho, uint views, uint group_shift, uint slot_mirrors, uint view_rep, uint write_flags,  \
      __global const float *depth_scales, __global const rf_depth_xform *depth_xforms, uint depth_instances

RF_INLINE rf_camera rf_make_camera(float scale_x, float scale_y, int kx0, int ky0, int width, int height, int xpair,
                                   int ypair, float frac_x, float frac_y, int ortho, uint views, uint group_shift,
                                   uint slot_mirrors, uint view_rep, uint write_flags) {
  rf_camera cam;
  cam.scale_x = scale_x;
  cam.scale_y = scale_y;
  cam.kx0 = kx0;
  cam.ky0 = ky0;
  cam.width = width;
  cam.height = height;
  cam.xpair = xpair;
  cam.ypair = ypair;
  cam.frac_x = frac_x;
  cam.frac_y = frac_y;
  cam.ortho = ortho;
  cam.views = views;
  cam.group_shift = group_shift;
  cam.slot_mirrors = slot_mirrors;
  cam.view_rep = view_rep;
  cam.write_flags = write_flags;
  return cam;
}

/* Where the answers go (rf_answers): `out`, or where it is null the planes
 * that are not. */
#define RF_ANSWER_ARGS                                                                                         \
  __global rf_pixel_hit *out, __global float *plane_z, __global float *plane_normal, __global float *plane_uv, \
      __global uint *plane_instance, __global uint *plane_primitive
#define RF_MAKE_ANSWERS() \
  { out, plane_z, plane_normal, plane_uv, plane_instance, plane_primitive }

#define RF_MAKE_CAMERA()                                                                                           \
  rf_make_camera(scale_x, scale_y, kx0, ky0, width, height, xpair, ypair, frac_x, frac_y, ortho, views, group_shift, \
                 slot_mirrors, view_rep, write_flags)

/* A masked scene's kernels (RF_ALPHA, rf_alpha.h) take its masks last. */
#ifdef RF_ALPHA
#define RF_ALPHA_KERNEL_ARGS                                                                                     \
  , __global const uint *alpha_index, __global const rf_alpha_tri *alpha_tris,                                   \
      __global const rf_alpha_image *alpha_images, __global const uchar *alpha_texels
#define RF_ALPHA_TABLES()                                                                        \
  const rf_alpha_tables alpha_tables = {alpha_index, alpha_tris, alpha_images, alpha_texels};     \
  const rf_alpha_tables* alpha = &alpha_tables
#else
#define RF_ALPHA_KERNEL_ARGS
#define RF_ALPHA_TABLES() (void)0
#endif

/* The single-ray kernel: one work-item per ray-list entry. */
__kernel void rf_trace_primary(__global const rf_node* nodes, __global const rf_tri* tris,
                               __global const rf_instance* instances, __global const rf_normal_xform* normal_xforms,
                               uint tlas_root, __global const uint* rays, uint ray_count, RF_CAMERA_ARGS,
                               RF_ANSWER_ARGS RF_ALPHA_KERNEL_ARGS) {
  const uint i = get_global_id(0);
  if (i >= ray_count) return;
  RF_ALPHA_TABLES();
  const rf_camera cam = RF_MAKE_CAMERA();
  const rf_depth_table depths = {depth_xforms, depth_instances};
  const rf_answers answers = RF_MAKE_ANSWERS();
  rf_trace_entry(rays[i], &cam, depth_scales, &depths, nodes, tris, instances, normal_xforms, tlas_root,
                 &answers RF_ALPHA_ARG);
}

/* Ray queries: one work-item per ray, through the 8-wide trees, the top
 * level's (tlas_wide, rf_trace_query_tlas_wide) and the bottom levels'
 * (wide, each instance's root in wide_roots); any_hit for occlusion.
 * Work-item k traces rays[k] and answers out[k]: the host hands the rays
 * over in the order they are traced (host/rays/ray_order.h) and puts the
 * answers back. Read through the order here, every ray was a cache and TLB
 * miss of its own in a 32 MB array (7% of the dragon's query time), and
 * answers written in place would be too (a store to a line not in the
 * cache holds up every later store of the core, the traversal stack's
 * included). */
__kernel void rf_trace_queries(__global const rf_node* nodes, __global const rf_wide8_node* wide,
                               __global const rf_wide8_node* tlas_wide, uint tlas_wide_root,
                               __global const uint* wide_roots, __global const rf_tri* tris,
                               __global const rf_instance* instances, __global const rf_normal_xform* normal_xforms,
                               uint tlas_root, __global const rf_query_ray* rays, uint ray_count, uint any_hit,
                               uint write_flags, __global rf_pixel_hit* out RF_ALPHA_KERNEL_ARGS) {
  const uint k = get_global_id(0);
  if (k >= ray_count) return;
  RF_ALPHA_TABLES();
  rf_trace_query(&rays[k], nodes, wide, tlas_wide, tlas_wide_root, wide_roots, tris, instances, normal_xforms, tlas_root,
                 any_hit != 0u, write_flags, &out[k] RF_ALPHA_ARG);
}

/* Ray queries that share their origin, a tile of up to RF_TILE_RAYS per
 * work-item (rf_tile.h, rf_trace_query_tile), read from the caller's world-
 * space arrays (rf_query_arrays): tile t covers traced rays tiles[t] ..
 * tiles[t + 1], every ray of it from the same origin; with `ordered`,
 * traced ray k is ray order[k] and answers out[order[k]]. */
__kernel void rf_trace_query_tiles(__global const rf_node* nodes, __global const rf_wide_node* wide,
                                   __global const rf_tri* tris, __global const rf_instance* instances,
                                   __global const rf_normal_xform* normal_xforms, uint tlas_root,
                                   __global const float* origins, __global const float* directions, float tmin,
                                   float tmax, int exponent, __global const uint* tiles, uint tile_count,
                                   uint write_flags, __global const uint* order, uint ordered,
                                   __global rf_pixel_hit* out RF_ALPHA_KERNEL_ARGS) {
  const uint t = get_global_id(0);
  if (t >= tile_count) return;
  RF_ALPHA_TABLES();
#ifdef RF_TILE_STATS
  uint stats[RF_TILE_STAT_COUNT];
  for (int k = 0; k < RF_TILE_STAT_COUNT; ++k) stats[k] = 0u;
#endif
  const uint begin = tiles[t];
  /* The next tile's directions, a quad row of four rays at a time, asked
   * for while this one traces: read in the tile's order through the
   * caller's rows, they were cache misses one after another. */
  if (t + 1 < tile_count) {
    const uint next = tiles[t + 1], next_count = tiles[t + 2] - next;
    for (uint l = 0; l < next_count; l += 4)
      RF_PREFETCH_LINE(directions + 3 * (size_t)(ordered ? order[next + l] : next + l));
  }
  const rf_query_arrays rays = {origins, directions, tmin, tmax, exponent};
  rf_trace_query_tile(&rays, begin, tiles[t + 1] - begin, nodes, wide, tris, instances, normal_xforms, tlas_root,
                      write_flags, ordered ? order : 0, out RF_TSTAT_ARG RF_ALPHA_ARG);
}

/* The tile kernel (rf_tile.h): one work-item per tile of the ray list; tile t
 * covers rays[tiles[t] .. tiles[t + 1]). PoCL runs it fastest with one
 * work-item per work-group: the SIMD is inside the work-item. */
__kernel void rf_trace_tiles(__global const rf_node* nodes, __global const rf_wide_node* wide,
                             __global const rf_tri* tris, __global const rf_instance* instances,
                             __global const rf_normal_xform* normal_xforms, uint tlas_root, __global const uint* rays,
                             __global const uint* tiles, uint tile_count, RF_CAMERA_ARGS, RF_ANSWER_ARGS
#ifdef RF_TILE_STATS
                             ,
                             __global uint* tile_stats
#endif
                                 RF_ALPHA_KERNEL_ARGS) {
  const uint t = get_global_id(0);
  if (t >= tile_count) return;
  RF_ALPHA_TABLES();
  const rf_camera cam = RF_MAKE_CAMERA();
  const uint begin = tiles[t];
#ifdef RF_TILE_STATS
  uint stats[RF_TILE_STAT_COUNT];
  for (int k = 0; k < RF_TILE_STAT_COUNT; ++k) stats[k] = 0u;
#endif
  const rf_depth_table depths = {depth_xforms, depth_instances};
  const rf_answers answers = RF_MAKE_ANSWERS();
  rf_trace_tile(rays, begin, tiles[t + 1] - begin, &cam, depth_scales, &depths, nodes, wide, tris, instances,
                normal_xforms, tlas_root, &answers RF_TSTAT_ARG RF_ALPHA_ARG);
#ifdef RF_TILE_STATS
  for (int k = 0; k < RF_TILE_STAT_COUNT; ++k) tile_stats[t * RF_TILE_STAT_COUNT + k] = stats[k];
#endif
}

/* Packs the planes `channels` (RF_PLANE_*) names of a pass's hits, view
 * after view, into `out` (rf_types.h gives a view's layout, words_per_view
 * words each), so that a device that is not the host's memory reads back
 * only those: 8 bytes a pixel for z and instance ids instead of 32.
 * groups_per_view work-groups of RF_PACK_GROUP pixels cover a view; each
 * adds the pixels of its view that hit to hit_counts[view] (zeroed first). */
__kernel __attribute__((reqd_work_group_size(RF_PACK_GROUP, 1, 1))) void rf_pack_planes(
    __global const rf_pixel_hit* hits, uint view_pixels, uint groups_per_view, uint channels, ulong words_per_view,
    __global uint* out, __global uint* hit_counts) {
  __local uint counts[RF_PACK_GROUP];
  const uint view = get_group_id(0) / groups_per_view;
  const uint lid = get_local_id(0);
  const uint p = (get_group_id(0) % groups_per_view) * RF_PACK_GROUP + lid;
  uint hit = 0u;
  if (p < view_pixels) {
    const rf_pixel_hit h = hits[(ulong)view * view_pixels + p];
    hit = h.instance != RF_INVALID ? 1u : 0u;
    __global uint* w = out + (ulong)view * words_per_view;
    const ulong n = view_pixels;
    if (channels & RF_PLANE_DEPTH) {
      w[p] = as_uint(h.z);
      w += n;
    }
    if (channels & RF_PLANE_NORMAL) {
      w[3 * (ulong)p] = as_uint(h.nx);
      w[3 * (ulong)p + 1] = as_uint(h.ny);
      w[3 * (ulong)p + 2] = as_uint(h.nz);
      w += 3 * n;
    }
    if (channels & RF_PLANE_UV) {
      w[2 * (ulong)p] = as_uint(h.u);
      w[2 * (ulong)p + 1] = as_uint(h.v);
      w += 2 * n;
    }
    if (channels & RF_PLANE_INSTANCE) {
      w[p] = h.instance;
      w += n;
    }
    if (channels & RF_PLANE_PRIMITIVE) w[p] = h.primitive;
  }
  /* One atomic per work-group: a per-pixel one on a single counter
   * serialises on GPUs. */
  counts[lid] = hit;
  barrier(CLK_LOCAL_MEM_FENCE);
  for (uint s = RF_PACK_GROUP / 2; s > 0u; s >>= 1) {
    if (lid < s) counts[lid] += counts[lid + s];
    barrier(CLK_LOCAL_MEM_FENCE);
  }
  if (lid == 0u && counts[0] != 0u) atomic_add(&hit_counts[view], counts[0]);
}
