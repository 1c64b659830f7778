/* rf_types.h - the compact traversal layout shared by host and device.
 *
 * Two spaces are normalised by powers of two, so that every float a kernel
 * computes is the same for a scene and camera scaled together by any power
 * of two (only the depth written out scales), and so that the watertight
 * test's quadratic and cubic terms stay far from the float range:
 *  - tree space: a mesh's object space in units of 2^e, e chosen per mesh so
 *    that its largest coordinate lies in [2^-8, 2) (host/bvh/blas.h);
 *  - trace space: camera space (eye at the origin, looking down -z) in units
 *    of 2^c, c chosen per frame from the eye's distance to the scene
 *    (host/fold/frame.h). A trace-space t times |d| times depth_scale (2^c) is the
 *    depth in world units.
 *
 * These structs are what the kernels read; the host's build-time trees
 * (host/bvh/bvh_build.h) are separate and are flattened into this layout.
 * Every field is 4 bytes and every struct a multiple of 4 bytes, so OpenCL C
 * and C++ agree on the layout without packing pragmas; host/device_layout.h
 * checks the sizes with static_assert.
 */
#ifndef RF_TYPES_H
#define RF_TYPES_H

#ifndef __OPENCL_C_VERSION__
#include "rf_common.h"
#endif

/* One BVH node, 32 bytes. Bottom-level and top-level nodes share one array.
 * The two children of an interior node sit next to each other (first,
 * first+1) at an even index, so both boxes come in one 64-byte line and the
 * traversal tests them together.
 *   bytes  0..11  bmin   box minimum (tree space for BLAS nodes, trace
 *                        space for TLAS nodes)
 *   bytes 12..15  first  BLAS: interior, index of the left child; leaf, first
 *                        triangle.
 *                        TLAS: bits 0..27 the left child or first instance,
 *                        bits 28..31 the leaf's instance count (0: interior)
 *   bytes 16..27  bmax   box maximum
 *   bytes 28..31  meta   BLAS: the leaf's triangle count, 0 for an interior
 *                        node.
 *                        TLAS: the transform groups that occur below this
 *                        node (bit g = group g; up to RF_GROUP_LIMIT) */
typedef struct {
  float bmin[3];
  rf_u32 first;
  float bmax[3];
  rf_u32 meta;
} rf_node;

/* One node of the 4-wide trees, 128 bytes: up to four children of a binary
 * node, collapsed from the binary tree below it (host/bvh/wide_bvh.h) with
 * the binary tree's own leaves, boxes and ranges, so a walk that takes a
 * ray's hits only from leaves its own slab test enters (the tile kernel's
 * lanes) finds the same hits as the binary traversal of the CPU reference.
 * The bottom-level trees' (tree space). Children's boxes side by side, so
 * one node brings all four in two 64-byte lines.
 *   bytes   0..95   lo_x, lo_y, lo_z, hi_x, hi_y, hi_z  child k's box in
 *                   element k of each
 *   bytes  96..111  child  interior child: its wide node; leaf: its first
 *                   triangle (top level: its first rf_instance)
 *   bytes 112..127  count  leaf: its triangle (instance) count; 0: an interior child;
 *                   RF_INVALID: no child in this slot (the slots in use
 *                   come first) */
typedef struct {
  float lo_x[4], lo_y[4], lo_z[4];
  float hi_x[4], hi_y[4], hi_z[4];
  rf_u32 child[4];
  rf_u32 count[4];
} rf_wide_node;

/* One node of the 8-wide trees, 256 bytes: rf_wide_node with eight
 * children, collapsed from the same binary trees (host/bvh/wide_bvh.h) for
 * the single-ray query kernel, whose scattered rays' walks are bound by the
 * steps they take: one step decides eight boxes in one AVX vector. Each
 * instance's whole tree (tree space), and a query frame's top level (trace
 * space; its leaves hold instances).
 *   bytes   0..191  lo_x, lo_y, lo_z, hi_x, hi_y, hi_z  child k's box in
 *                   element k of each
 *   bytes 192..223  child  interior child: its 8-wide node; leaf: its first
 *                   triangle (top level: its first rf_instance)
 *   bytes 224..255  count  as rf_wide_node's */
typedef struct {
  float lo_x[8], lo_y[8], lo_z[8];
  float hi_x[8], hi_y[8], hi_z[8];
  rf_u32 child[8];
  rf_u32 count[8];
} rf_wide8_node;

/* Deepest traversal stack of every kernel; the builders cap tree depth
 * below it (host/bvh/bvh_flatten.cpp checks). */
#define RF_STACK_SIZE 64

#define RF_NODE_COUNT_MASK 0x00FFFFFFu
#define RF_TLAS_COUNT_SHIFT 28u
#define RF_TLAS_INDEX_MASK 0x0FFFFFFFu
#define RF_TLAS_MAX_LEAF 15u

/* Transform groups. A trace answers up to RF_GROUP_LIMIT (view, mirror)
 * pairs at once: group g = view * S + slot, where S (1, 2 or 4, a power of
 * two: rf_camera.group_shift = log2 S) is the number of mirrors the fold
 * uses and slot s stands for mirror (rf_camera.slot_mirrors >> 2s) & 3
 * (bit 0: camera x negated, bit 1: camera y). One view unfolded is group 0
 * alone. RF_MAX_GROUPS is how many one build of the traversal holds: the
 * host's reference all of them, the device programs as many as the pass
 * needs (4 unless views are aligned; host/opencl/cl_tracer.h). */
#define RF_GROUP_LIMIT 32
#define RF_MIRRORS 4
#ifndef RF_MAX_GROUPS
#define RF_MAX_GROUPS RF_GROUP_LIMIT
#endif

/* Count-trailing-zeros of a nonzero mask, through clz (OpenCL C 1.2). */
#ifdef __OPENCL_C_VERSION__
#define RF_CTZ(m) (31u - clz((m) & (0u - (m))))
#else
#define RF_CTZ(m) ((rf_u32)__builtin_ctz(m))
#endif

/* for each set bit g of mask (an rf_u32 expression), lowest first: a fixed
 * loop for the 4 groups of one view (unrolled, as before views existed),
 * else a walk over the set bits. */
#if RF_MAX_GROUPS <= 4
#define RF_FOR_EACH_GROUP(g, mask) \
  for (rf_u32 g = 0, rf_gm_ = (mask); g < (rf_u32)RF_MAX_GROUPS; ++g) \
    if ((rf_gm_ >> g) & 1u)
#else
#define RF_FOR_EACH_GROUP(g, mask) \
  for (rf_u32 rf_gm_ = (mask), g = rf_gm_ ? RF_CTZ(rf_gm_) : 0u; rf_gm_ != 0u; \
       rf_gm_ &= rf_gm_ - 1u, g = rf_gm_ ? RF_CTZ(rf_gm_) : 0u)
#endif

/* One triangle in BVH leaf order, 56 bytes.
 *   bytes  0..35  v0, v1, v2   tree-space vertices, in the file's winding
 *   bytes 36..47  n            cross(v1 - v0, v2 - v0) in float, as
 *                              rf_tri_set_normal computes it (the distance
 *                              and the normal read it; made once on the host)
 *   bytes 48..51  prim         triangle index within its mesh, as in the file
 *                              (after strips and fans are made triangles)
 *   bytes 52..55  inst         added to the traced instance's instance_id to
 *                              give the hit's scene instance: 0 in a mesh's
 *                              own tree (shared by every instance of the
 *                              mesh), the member's id less the first
 *                              member's in a tree merged from the static
 *                              instances of one transform (bvh/blas.h) */
typedef struct {
  float v0[3];
  float v1[3];
  float v2[3];
  float n[3];
  rf_u32 prim;
  rf_u32 inst;
} rf_tri;

/* One traced instance (a scene instance, or a mirrored copy of one), 64 bytes.
 *   bytes  0..47  tree_from_trace  row-major 3x4 affine: row r is
 *                 (m[4r], m[4r+1], m[4r+2]) with translation m[4r+3].
 *                 Rays stay unnormalised under it, so a hit's t is the same
 *                 parameter in trace and tree space.
 *   bytes 48..51  blas_root    node index of the mesh's bottom-level root
 *                              (or of the subtree re-braiding opened)
 *   bytes 52..55  instance_id  index of the scene instance (of the first
 *                              member, for a merged tree: a hit's instance
 *                              is this plus its rf_tri's inst); mirrored
 *                              copies keep the id of the instance they mirror
 *   bytes 56..59  group        transform group (see above; 0 = view 0
 *                              not mirrored)
 *   bytes 60..63  wide_root    the rf_wide_node holding blas_root's
 *                              children (the 4-wide tree's);
 *                              RF_INVALID when blas_root is a leaf, and
 *                              in a query frame of whole trees, whose
 *                              8-wide roots are an array of their own
 *                              (rf_trace_queries' wide_roots) */
typedef struct {
  float tree_from_trace[12];
  rf_u32 blas_root;
  rf_u32 instance_id;
  rf_u32 group;
  rf_u32 wide_root;
} rf_instance;

/* Per scene instance, 36 bytes: the row-major 3x3 that takes a tree-space
 * normal to world space (the inverse transpose of world_from_tree), so the
 * normal keeps the file's front side also under mirroring node transforms. */
typedef struct {
  float m[9];
} rf_normal_xform;

/* Alpha masks (glTF alphaMode MASK; rf_alpha.h). Per triangle of a mesh
 * with a masked primitive, 48 bytes (host/bvh/alpha_tables.h makes them):
 *   bytes  0..23  uv      the corners' texture coordinates (u, v) of the
 *                         base colour texture's set, KHR_texture_transform
 *                         applied (in double, rounded once)
 *   bytes 24..35  alpha   the corners' alpha: baseColorFactor's times COLOR_0's
 *   bytes 36..39  cutoff  alphaCutoff; -inf for an opaque triangle (a
 *                         primitive of the mesh whose material is not MASK)
 *   bytes 40..43  image   its base colour texture's rf_alpha_image,
 *                         RF_INVALID for none
 *   bytes 44..47  unused */
typedef struct {
  float uv[6];
  float alpha[3];
  float cutoff;
  rf_u32 image;
  rf_u32 unused;
} rf_alpha_tri;

/* A base colour texture's alpha at level 0, 16 bytes:
 *   bytes  0..3   offset  its first texel in the texel array (one byte a
 *                         texel, rows top first)
 *   bytes  4..11  width, height
 *   bytes 12..15  wrap    bits 0..1 wrapS, 2..3 wrapT: 0 repeat, 1 clamp to
 *                         edge, 2 mirrored repeat */
typedef struct {
  rf_u32 offset;
  rf_u32 width;
  rf_u32 height;
  rf_u32 wrap;
} rf_alpha_image;

#define RF_WRAP_REPEAT 0u
#define RF_WRAP_CLAMP 1u
#define RF_WRAP_MIRROR 2u

/* The exact-depth transform (rf_depth.h) of one scene instance in one view,
 * 96 bytes: the pixel's exact ray in the instance's tree space as
 * double-float pairs, each a value hi + lo (hi the float nearest the double,
 * lo the float nearest the rest), of the pixel offsets ix = 2x + kx0 and
 * iy = ky0 - 2y:
 *   bytes  0..23  a  hi[3] then lo[3]: the ray's change per unit of ix
 *   bytes 24..47  b  the same per unit of iy
 *   bytes 48..71  c  perspective: the direction at ix = iy = 0;
 *                    orthographic: the direction
 *   bytes 72..95  o  perspective: the origin (the eye); orthographic: the
 *                    origin at ix = iy = 0
 * (perspective o + t (a ix + b iy + c), orthographic (o + a ix + b iy) + t c).
 * A pass's table holds, view after view, the view's camera entry (the same
 * in trace space: tree_from_trace the identity) then one entry per scene
 * instance; hidden instances' entries are zero and never read. */
typedef struct {
  float m[24];
} rf_depth_xform;

/* The hit info of one pixel, 32 bytes: the layout of the output buffer.
 *   z          distance from the eye along the normalised ray, +inf on a miss
 *   nx, ny, nz world-space geometric normal, unit length (0 on a miss)
 *   u, v       barycentrics of v1 and v2 (0 on a miss)
 *   instance   scene instance index, RF_INVALID on a miss
 *   primitive  triangle index within the mesh, RF_INVALID on a miss */
typedef struct {
  float z;
  float nx, ny, nz;
  float u, v;
  rf_u32 instance;
  rf_u32 primitive;
} rf_pixel_hit;

/* Where a camera kernel puts its answers (rf_put_answer): each pixel's
 * rf_pixel_hit at hits[i], or, where hits is null, its fields into the
 * planes of a G-buffer (RF_PLANE_*), each null where not asked for:
 *   z[i], normal[3i .. 3i + 2], uv[2i .. 2i + 1], instance[i], primitive[i].
 * On a CPU device the planes are the caller's memory, written in place:
 * the host's pass from 32-byte hits to planes was a tenth of a 720p frame
 * on the armadillo. */
typedef struct {
  RF_GLOBAL rf_pixel_hit* hits;
  RF_GLOBAL float* z;
  RF_GLOBAL float* normal;
  RF_GLOBAL float* uv;
  RF_GLOBAL rf_u32* instance;
  RF_GLOBAL rf_u32* primitive;
} rf_answers;

/* Answers into `hits` alone. */
RF_INLINE rf_answers rf_answers_in(RF_GLOBAL rf_pixel_hit* hits) {
  rf_answers a;
  a.hits = hits;
  a.z = a.normal = a.uv = 0;
  a.instance = a.primitive = 0;
  return a;
}

/* Puts answer px at index i (pixel of the pass, or ray). */
RF_INLINE void rf_put_answer(const rf_answers* a, size_t i, const rf_pixel_hit* px) {
  if (a->hits) {
    a->hits[i] = *px;
    return;
  }
  if (a->z) a->z[i] = px->z;
  if (a->normal) {
    a->normal[3 * i] = px->nx;
    a->normal[3 * i + 1] = px->ny;
    a->normal[3 * i + 2] = px->nz;
  }
  if (a->uv) {
    a->uv[2 * i] = px->u;
    a->uv[2 * i + 1] = px->v;
  }
  if (a->instance) a->instance[i] = px->instance;
  if (a->primitive) a->primitive[i] = px->primitive;
}

/* The planes of a packed readback (rf_pack_planes), as bits; the same
 * values as the public API's Channels (host/include/rayfold/gbuffer.h). A
 * view's packed words hold the planes asked for in this order, each for
 * every pixel: z (1 word), normal (3, interleaved), uv (2, interleaved),
 * instance (1), primitive (1); floats as their bits. */
#define RF_PLANE_DEPTH 1u
#define RF_PLANE_NORMAL 2u
#define RF_PLANE_UV 4u
#define RF_PLANE_INSTANCE 8u
#define RF_PLANE_PRIMITIVE 16u
#define RF_PLANE_ALL 31u
#define RF_PACK_GROUP 256 /* pixels per work-group of rf_pack_planes */

/* One ray query (scene.intersect, scene.occluded), 32 bytes, trace space:
 *   bytes  0..11  o     origin
 *   bytes 12..15  tmin  a hit counts from beyond this ray parameter ...
 *   bytes 16..27  d     direction, not normalised: t is along it
 *   bytes 28..31  tmax  ... up to and including this one
 * Its answer is an rf_pixel_hit whose z is t (+inf on a miss). */
typedef struct {
  float o[3];
  float tmin;
  float d[3];
  float tmax;
} rf_query_ray;

/* One entry of the compacted ray list, 4 bytes:
 *   bits  0..14  pixel column x of the traced ray
 *   bits 15..29  pixel row y
 *   bit  30      the ray also answers the pixel mirrored in x (column
 *                xpair - x), through the instances mirrored in camera x
 *   bit  31      the ray also answers the pixel mirrored in y (row
 *                ypair - y), through those mirrored in camera y; with both
 *                bits it answers a fourth pixel through those mirrored in both
 * In a pass of several views the ray answers these pixels in every view. */
#define RF_RAY_COORD_BITS 15u
#define RF_RAY_COORD_MASK 0x7FFFu
#define RF_RAY_MIRROR_X (1u << 30)
#define RF_RAY_MIRROR_Y (1u << 31)
#define RF_MAX_IMAGE_SIDE 32767

/* The ray list is ordered in tiles: the traced pixels of each 16x16 block of
 * the image, in 8x8 blocks (the single-ray kernel's work-groups) of 4x4
 * quads (a tile kernel vector of 8 rays is a 4x2 block, of 16 a 4x4 one). The tile table, one 4-byte entry per tile
 * plus one, gives tile t the entries [tiles[t], tiles[t + 1]) of the list: at most RF_TILE_RAYS, fewer at the image
 * border and the edges of the traced region; empty tiles are left out. */
#define RF_TILE_SIDE 16
#define RF_TILE_RAYS (RF_TILE_SIDE * RF_TILE_SIDE)

/* The tile kernel's traversal counters, a diagnostic (rayfold-stats): built
 * with RF_TILE_STATS, the kernel writes RF_TILE_STAT_COUNT 4-byte counters
 * per tile, in this order, to one more buffer. */
#define RF_TILE_STAT_TLAS_NODES 0      /* top-level nodes popped and not skipped */
#define RF_TILE_STAT_TLAS_LANE_BOXES 1 /* lane-group slab tests in the top level */
#define RF_TILE_STAT_INSTANCES 2       /* instance subtrees entered */
#define RF_TILE_STAT_SETUPS 3          /* object-space set-ups of the tile's rays */
#define RF_TILE_STAT_BLAS_NODES 4      /* bottom-level nodes popped and not skipped */
#define RF_TILE_STAT_BLAS_LANE_BOXES 5 /* lane-group slab tests in the bottom level */
#define RF_TILE_STAT_LEAVES 6          /* leaves with a lane group inside */
#define RF_TILE_STAT_TRI_LANES 7       /* lane-group triangle tests */
#define RF_TILE_STAT_COUNT 8

/* How pixel (x, y) becomes a trace-space ray, origin at the eye:
 *   d = (scale_x * ((float)(2x + kx0) + frac_x), scale_y * ((float)(ky0 - 2y) + frac_y), -1)
 * and a hit at parameter t of view v a depth: (t * |d|) * depth_scales[v],
 * the power of two of that view's trace space.
 * The integer offsets keep mirror partners exact: the column xpair - x gives
 * exactly the negated float. A centred W x H image has kx0 = 1 - W,
 * ky0 = H - 1, xpair = W - 1, ypair = H - 1. frac_x and frac_y, in half
 * pixels and within (-1, 1), place a principal point off the half-pixel grid
 * (a calibrated camera's); they are 0 for every camera that can fold, and
 * adding 0 leaves the integer's float unchanged.
 * An orthographic camera (ortho = 1) sends pixel (x, y) from o = (dx, dy, 0)
 * along (0, 0, -1) instead; a hit at t is at depth t * depth_scales[v] from
 * the image plane. Mirror partners keep exactly negated origins.
 * The last four fields describe the pass, not the camera: views traced
 * together (all with these rays; their instances differ) and the group
 * layout above. view_rep has bit v * S set for every view v, so a ray's
 * groups are its slot mask times view_rep. One view, unfolded: 1, 0, 0, 1.
 * write_flags change what a pixel's hit info holds:
 *   RF_WRITE_NO_NORMALS   a zero normal instead of the computed one (a
 *                         render that asked for no normal plane: the
 *                         normal's divisions and square root were a tenth
 *                         of an interior's trace)
 *   RF_WRITE_PLANAR_DEPTH z is the depth along the camera's axis instead
 *                         of the distance along the ray
 *   RF_WRITE_EXACT_DEPTH  z is rf_depth.h's: from the pixel's exact ray
 *                         and the hit triangle's plane in double-float,
 *                         rounded once, instead of (t * |d|) times the
 *                         depth scale (planar: t times it) from the
 *                         traversal's float t */
#define RF_WRITE_NO_NORMALS 1u
#define RF_WRITE_PLANAR_DEPTH 2u
#define RF_WRITE_EXACT_DEPTH 4u
typedef struct {
  float scale_x, scale_y;
  rf_i32 kx0, ky0;
  rf_i32 width, height;
  rf_i32 xpair, ypair;
  float frac_x, frac_y;
  rf_i32 ortho;
  rf_u32 views;
  rf_u32 group_shift;
  rf_u32 slot_mirrors;
  rf_u32 view_rep;
  rf_u32 write_flags;
} rf_camera;

#endif /* RF_TYPES_H */
