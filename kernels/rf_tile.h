/* rf_tile.h - the tile kernel's traversal: one work-item traces a tile of up
 * to RF_TILE_RAYS rays of the compacted ray list, one ray per vector lane
 * (rf_lanes.h). Device only.
 *
 * Why a tile: PoCL runs one work-item per CPU thread at a time, so SIMD must
 * come from inside the work-item. Primary rays share the eye as origin; a
 * tile of neighbouring rays visits nearly the same nodes, so the tile visits
 * a node once for all its rays:
 *  - a node is skipped for the whole tile when rf_interval_box (exact bounds
 *    over the tile's reciprocal directions) rejects it, or when no lane's own
 *    slab test passes it;
 *  - each lane keeps its own closest hit per transform group and its own
 *    tmax, so every lane finds the same closest hit as the scalar code: the
 *    traversal only visits more than one ray needs, never less, and the tie
 *    rule makes the result independent of the order of visits;
 *  - a leaf tests its triangles only on the lane groups (vectors) with a ray
 *    inside its box;
 *  - a lane takes a hit only from a leaf its own slab test enters, below a
 *    top-level leaf its own test enters. This is what makes a lane equal the
 *    scalar code, not just close to it: the scalar slab test is not
 *    conservative on a box face that a ray with a zero direction component
 *    runs along (the slab there collapses to one side), while the watertight
 *    triangle test includes edges, so the scalar result is the closest hit
 *    among the triangles its own box tests reach. A lane that passes a leaf
 *    passes every ancestor (boxes nest, slab ends are monotone under
 *    rounding, tmax only shrinks), so the leaf's and the top-level leaf's
 *    tests decide exactly that set.
 * Lanes past the tile's ray count repeat its last ray, so they never widen
 * the tile's bounds; their results are not written.
 */
#ifndef RF_TILE_H
#define RF_TILE_H

#define RF_LANE_GROUPS (RF_TILE_RAYS / RF_LANES)

/* Counters (rf_types.h) only in the diagnostic build. */
#ifdef RF_TILE_STATS
#define RF_TSTAT_PARAM , rf_u32* stats
#define RF_TSTAT_ARG , stats
#define RF_TSTAT(k, n) (stats[k] += (n))
#else
#define RF_TSTAT_PARAM
#define RF_TSTAT_ARG
#define RF_TSTAT(k, n) ((void)0)
#endif

/* The tile's camera-space rays, 4 KiB: direction (dz = -1, so the
 * reciprocal's z is -1 in every lane) and reciprocal x, y per lane, and the
 * reciprocal ranges over the tile for rf_interval_box. */
typedef struct {
  rf_vf dx[RF_LANE_GROUPS], dy[RF_LANE_GROUPS];
  rf_vf ix[RF_LANE_GROUPS], iy[RF_LANE_GROUPS];
  float lo[3], hi[3];
} rf_tile_camera;

/* What a tile of ray queries adds to its rays (rf_trace_query_tile): the
 * origin they share, per lane the direction's z and its reciprocal (no
 * longer -1) and the ray's tmin, 3 KiB. A camera tile passes none. */
typedef struct {
  float o[3];
  rf_vf dz[RF_LANE_GROUPS], iz[RF_LANE_GROUPS];
  rf_vf tmin[RF_LANE_GROUPS];
} rf_tile_query;

/* Ray queries as the caller gave them, in world space: ray i's origin
 * origins[3i .. 3i + 2] and direction directions[3i .. 3i + 2], one interval
 * (tmin, tmax] for all. The tile takes them to trace space by 2^exponent as
 * the host's to_trace_space does for the single-ray kernel and the CPU
 * reference (util/pow2.h), so the same bits: without a pass that gathers
 * them into 32-byte rf_query_rays first (a tenth of a camera-array query). */
typedef struct {
  const RF_GLOBAL float* origins;
  const RF_GLOBAL float* directions;
  float tmin, tmax;
  rf_i32 exponent;
} rf_query_arrays;

/* x * 2^e as Pow2Scale (host/util/pow2.h): a product where 2^e is a normal
 * float (exact while the result is one, rounded as ldexp otherwise), else
 * ldexp; both correctly rounded. */
RF_INLINE float rf_pow2_scale(float x, rf_i32 e) { return e > -126 && e < 126 ? x * ldexp(1.0f, e) : ldexp(x, e); }

/* The tile's rays in one instance's object space, 9 KiB: the shared origin
 * (the instance's translation column), per lane the reciprocal direction and
 * the shear and axis permutation of the watertight test, as rf_ray_init
 * makes them. When every lane has the same permutation (nearly every tile)
 * it is kept once in kx, ky, kz and the triangle test needs no per-lane
 * selection. */
typedef struct {
  float o[3];
  float lo[3], hi[3];
  rf_i32 uniform, kx, ky, kz;
  /* The bits of the tree_from_trace these rays were made with: equal
   * bits give equal rays, so instances with the same transform (every node
   * of many real files) and the subtrees of one instance share a set-up. */
  rf_u32 key[12];
  rf_i32 valid;
  rf_vf ix[RF_LANE_GROUPS], iy[RF_LANE_GROUPS], iz[RF_LANE_GROUPS];
  rf_vf sx[RF_LANE_GROUPS], sy[RF_LANE_GROUPS], sz[RF_LANE_GROUPS];
  rf_vi pkx[RF_LANE_GROUPS], pky[RF_LANE_GROUPS], pkz[RF_LANE_GROUPS];
} rf_tile_ray;

/* Per lane, the closest hit of one transform group (rf_hit's fields), 6 KiB.
 * A lane that does not answer the group holds t = -1, which nothing beats
 * and which never keeps a node alive. tmax is the largest t over the lanes:
 * the bound for skipping a node for the whole tile. */
typedef struct {
  rf_vf t[RF_LANE_GROUPS], u[RF_LANE_GROUPS], v[RF_LANE_GROUPS];
  rf_vu instance[RF_LANE_GROUPS], prim[RF_LANE_GROUPS], tri[RF_LANE_GROUPS];
  float tmax;
} rf_tile_hits;

/* Four running maxima, not one: the compiler keeps the order of the
 * maxima (their NaN rule), and one chain of 32 waited on each one before
 * (5% of the dragon's leaf time). The lanes hold no NaN, so the value is
 * the same (a zero's sign aside, which no comparison with it sees). */
#if RF_LANE_GROUPS % 4 != 0
#error "rf_tile_update_tmax takes the lane groups four at a time"
#endif
RF_INLINE void rf_tile_update_tmax(rf_tile_hits* h) {
  rf_vf m0 = h->t[0], m1 = h->t[1], m2 = h->t[2], m3 = h->t[3];
  for (int j = 4; j < RF_LANE_GROUPS; j += 4) {
    m0 = rf_lanes_max(m0, h->t[j]);
    m1 = rf_lanes_max(m1, h->t[j + 1]);
    m2 = rf_lanes_max(m2, h->t[j + 2]);
    m3 = rf_lanes_max(m3, h->t[j + 3]);
  }
  h->tmax = rf_lanes_hmax(rf_lanes_max(rf_lanes_max(m0, m1), rf_lanes_max(m2, m3)));
}

/* rf_ray_to_object and rf_ray_init for every lane of the tile, unless r
 * already holds the rays of a transform with the same bits. */
RF_INLINE void rf_tile_to_object(rf_tile_ray* r, const RF_GLOBAL float* m, const rf_tile_camera* cam,
                                 const rf_tile_query* q RF_TSTAT_PARAM) {
  if (r->valid) {
    rf_u32 diff = 0u;
    for (int i = 0; i < 12; ++i) diff |= as_uint(m[i]) ^ r->key[i];
    if (diff == 0u) return;
  }
  RF_TSTAT(RF_TILE_STAT_SETUPS, 1);
  r->valid = 1;
  for (int i = 0; i < 12; ++i) r->key[i] = as_uint(m[i]);
  if (q) { /* rf_ray_to_object_at's origin, once for the tile */
    const float ox = q->o[0], oy = q->o[1], oz = q->o[2];
    r->o[0] = ((m[0] * ox + m[1] * oy) + m[2] * oz) + m[3];
    r->o[1] = ((m[4] * ox + m[5] * oy) + m[6] * oz) + m[7];
    r->o[2] = ((m[8] * ox + m[9] * oy) + m[10] * oz) + m[11];
  } else {
    r->o[0] = m[3];
    r->o[1] = m[7];
    r->o[2] = m[11];
  }
  rf_vf lo0 = (rf_vf)(RF_FAR), lo1 = lo0, lo2 = lo0, hi0 = (rf_vf)(-RF_FAR), hi1 = hi0, hi2 = hi0;
  rf_vi diff = (rf_vi)(0);
  rf_i32 kx0 = 0, ky0 = 0, kz0 = 0;
  for (int j = 0; j < RF_LANE_GROUPS; ++j) {
    const rf_vf dx = cam->dx[j], dy = cam->dy[j], dz = q ? q->dz[j] : (rf_vf)(-1.0f);
    const rf_vf ex = m[0] * dx + m[1] * dy + m[2] * dz;
    const rf_vf ey = m[4] * dx + m[5] * dy + m[6] * dz;
    const rf_vf ez = m[8] * dx + m[9] * dy + m[10] * dz;
    const rf_vf ix = rf_lanes_reciprocal(ex), iy = rf_lanes_reciprocal(ey), iz = rf_lanes_reciprocal(ez);
    const rf_vf ax = fabs(ex), ay = fabs(ey), az = fabs(ez);
    rf_vi kz = select((rf_vi)(0), (rf_vi)(1), ay > ax);
    kz = select(kz, (rf_vi)(2), az > select(ax, ay, kz == 1));
    rf_vi kx = select(kz + 1, (rf_vi)(0), kz + 1 == 3);
    rf_vi ky = select(kx + 1, (rf_vi)(0), kx + 1 == 3);
    const rf_vi swap = rf_lanes_pick_v(ex, ey, ez, kz) < (rf_vf)(0.0f);
    const rf_vi t = kx;
    kx = select(kx, ky, swap);
    ky = select(ky, t, swap);
    const rf_vf sz = rf_lanes_pick_v(ix, iy, iz, kz);
    r->ix[j] = ix;
    r->iy[j] = iy;
    r->iz[j] = iz;
    r->sz[j] = sz;
    r->sx[j] = rf_lanes_pick_v(ex, ey, ez, kx) * sz;
    r->sy[j] = rf_lanes_pick_v(ex, ey, ez, ky) * sz;
    r->pkx[j] = kx;
    r->pky[j] = ky;
    r->pkz[j] = kz;
    if (j == 0) {
      kx0 = kx.s0;
      ky0 = ky.s0;
      kz0 = kz.s0;
    }
    diff |= (kx != kx0) | (ky != ky0) | (kz != kz0);
    lo0 = fmin(lo0, ix);
    lo1 = fmin(lo1, iy);
    lo2 = fmin(lo2, iz);
    hi0 = fmax(hi0, ix);
    hi1 = fmax(hi1, iy);
    hi2 = fmax(hi2, iz);
  }
  r->lo[0] = rf_lanes_hmin(lo0);
  r->lo[1] = rf_lanes_hmin(lo1);
  r->lo[2] = rf_lanes_hmin(lo2);
  r->hi[0] = rf_lanes_hmax(hi0);
  r->hi[1] = rf_lanes_hmax(hi1);
  r->hi[2] = rf_lanes_hmax(hi2);
  r->uniform = !rf_lanes_any(diff);
  r->kx = kx0;
  r->ky = ky0;
  r->kz = kz0;
}

#ifdef RF_ALPHA
/* The lanes of `take` whose hit (u, v) on triangle ti its mask keeps
 * (rf_alpha_keeps, lane by lane). */
RF_INLINE rf_vi rf_tile_alpha(const rf_alpha_tables* alpha, rf_u32 ti, rf_vi take, rf_vf u, rf_vf v) {
  rf_vi keep = take;
  for (int l = 0; l < RF_LANES; ++l)
    if (((const int*)&take)[l] != 0)
      ((int*)&keep)[l] = rf_alpha_keeps(alpha, ti, ((const float*)&u)[l], ((const float*)&v)[l]) ? -1 : 0;
  return keep;
}
#endif

/* Tests one triangle on the lane groups in `lanes` (bit j: group j) and takes
 * the hit of every lane in lane_in (the lanes whose own slab tests reach the
 * leaf) that beats the lane's current one by the tie rule, at a distance no
 * nearer than the lane's entry into the leaf, leaf_t (rf_hit_distance).
 * Returns nonzero when some lane took it. Always inlined into the leaf's
 * loop: PoCL kept it a call with a 1.5 KiB frame and its leaf-invariant
 * loads in the loop (with the loads above, random views of the dragon and
 * the armadillo 1.02x to 1.03x faster, interiors 1.01x to 1.03x). */
RF_INLINE_ALWAYS int rf_tile_triangle(const RF_GLOBAL rf_tri* tri, rf_u32 ti, const rf_tile_ray* r, rf_u32 instance_id,
                                      rf_u32 lanes, const rf_vi* lane_in, const rf_vf* leaf_t, const rf_vf* tmin,
                                      rf_tile_hits* h RF_TSTAT_PARAM RF_ALPHA_PARAM) {
  const float a0 = tri->v0[0] - r->o[0], a1 = tri->v0[1] - r->o[1], a2 = tri->v0[2] - r->o[2];
  const float b0 = tri->v1[0] - r->o[0], b1 = tri->v1[1] - r->o[1], b2 = tri->v1[2] - r->o[2];
  const float c0 = tri->v2[0] - r->o[0], c1 = tri->v2[1] - r->o[1], c2 = tri->v2[2] - r->o[2];
  const rf_u32 prim = tri->prim;
  const rf_vu inst_v = (rf_vu)(instance_id + tri->inst), prim_v = (rf_vu)(prim);
  /* The uniform permutation, once for all lanes: each coordinate loaded at
   * its axis, less the origin's there (a0 .. c2's values, permuted). Read
   * through arrays indexed by the axes, each was a store and a load. */
  const rf_i32 kx = r->kx, ky = r->ky, kz = r->kz;
  const float uax = tri->v0[kx] - r->o[kx], uay = tri->v0[ky] - r->o[ky], uaz = tri->v0[kz] - r->o[kz];
  const float ubx = tri->v1[kx] - r->o[kx], uby = tri->v1[ky] - r->o[ky], ubz = tri->v1[kz] - r->o[kz];
  const float ucx = tri->v2[kx] - r->o[kx], ucy = tri->v2[ky] - r->o[ky], ucz = tri->v2[kz] - r->o[kz];
  const float n[3] = {tri->n[0], tri->n[1], tri->n[2]};
  const float unx = tri->n[kx], uny = tri->n[ky], unz = tri->n[kz];
  /* The distance formula, once for the tile where the permutation is; the
   * plane's offset only where some lane may take it. */
  const int woop_u = r->uniform && rf_woop_distance_suits(uaz, ubz, ucz);
  const float offset = woop_u ? 0.0f : rf_plane_offset(tri, r->o);
  int taken = 0;
  /* Over the set bits only: a leaf's triangles meet about three of the 32
   * groups on dense meshes, and a test of every bit cost a fifth of this
   * function's time there (the dragon's). */
  for (rf_u32 m = lanes; m != 0u; m &= m - 1u) {
    const int j = (int)RF_CTZ(m);
    RF_TSTAT(RF_TILE_STAT_TRI_LANES, 1);
    rf_vf t, ev, ew, det;
    rf_vi ok;
    if (r->uniform) {
      ok =
          rf_lanes_triangle((rf_vf)(uax), (rf_vf)(uay), (rf_vf)(uaz), (rf_vf)(ubx), (rf_vf)(uby), (rf_vf)(ubz),
                            (rf_vf)(ucx), (rf_vf)(ucy), (rf_vf)(ucz), r->sx[j], r->sy[j], r->sz[j], (rf_vf)(unx),
                            (rf_vf)(uny), (rf_vf)(unz), (rf_vi)(woop_u ? -1 : 0), offset, &t, &ev, &ew, &det);
    } else {
      const rf_vi kx = r->pkx[j], ky = r->pky[j], kz = r->pkz[j];
      const rf_vf az = rf_lanes_pick(a0, a1, a2, kz), bz = rf_lanes_pick(b0, b1, b2, kz);
      const rf_vf cz = rf_lanes_pick(c0, c1, c2, kz);
      ok = rf_lanes_triangle(rf_lanes_pick(a0, a1, a2, kx), rf_lanes_pick(a0, a1, a2, ky), az,
                             rf_lanes_pick(b0, b1, b2, kx), rf_lanes_pick(b0, b1, b2, ky), bz,
                             rf_lanes_pick(c0, c1, c2, kx), rf_lanes_pick(c0, c1, c2, ky), cz, r->sx[j], r->sy[j],
                             r->sz[j], rf_lanes_pick(n[0], n[1], n[2], kx), rf_lanes_pick(n[0], n[1], n[2], ky),
                             rf_lanes_pick(n[0], n[1], n[2], kz), rf_lanes_woop_suits(az, bz, cz), offset, &t, &ev,
                             &ew, &det);
    }
    if (!rf_lanes_any(ok)) continue;
    const rf_vi positive = t > (tmin ? tmin[j] : (rf_vf)(0.0f)); /* beyond tmin: 0 for camera rays */
    /* rf_hit_is_closer lane by lane. */
    t = select(t, leaf_t[j], t < leaf_t[j]); /* rf_hit_distance */
    const rf_vf bt = h->t[j];
    const rf_vu bi = h->instance[j];
    const rf_vi closer = (t < bt) | ((t == bt) & ((inst_v < bi) | ((inst_v == bi) & (prim_v < h->prim[j]))));
    /* lane_in compared again rather than used as read: a mask the compiler
     * sees come from a comparison is tested in one instruction, a loaded
     * one through an OR tree (6% of the dragon's time). */
    rf_vi take = ok & positive & closer & (lane_in[j] != (rf_vi)(0));
    if (!rf_lanes_any(take)) continue;
#ifdef RF_ALPHA
    /* A masked triangle's lanes keep only the hits its alpha keeps, each
     * lane's test that of the scalar trace (rf_alpha.h). */
    if (alpha->index[ti] != RF_INVALID) {
      take = rf_tile_alpha(alpha, ti, take, ev / det, ew / det);
      if (!rf_lanes_any(take)) continue;
    }
#endif
    h->t[j] = select(bt, t, take);
    h->u[j] = select(h->u[j], ev / det, take);
    h->v[j] = select(h->v[j], ew / det, take);
    h->instance[j] = select(bi, inst_v, take);
    h->prim[j] = select(h->prim[j], prim_v, take);
    h->tri[j] = select(h->tri[j], (rf_vu)(ti), take);
    taken = 1;
  }
  return taken;
}

/* The lane groups [first, last] of the tile that may still enter a node,
 * packed in one stack word. A lane whose slab test fails on a box fails on
 * every box inside it (each slab end is monotone in the box's bounds under
 * rounding, and a lane's tmax only shrinks), and a child's box lies inside
 * its parent's (rf_types.h), so the lane groups before the first and after
 * the last that enter a node never need testing below it. */
#define RF_RANGE(first, last) ((rf_u32)(first) | ((rf_u32)(last) << 8))
#define RF_RANGE_FIRST(r) ((int)((r)&0xFFu))
#define RF_RANGE_LAST(r) ((int)((r) >> 8))
/* The range's lane groups as a mask (bit j: group j). */
#define RF_RANGE_MASK(first, last) (((2u << (last)) - 1u) & ~((1u << (first)) - 1u))

/* Pushes the children c and c + 1 that their whole-tile bounds tc did not
 * reject, the far one first so that the near one is visited next; returns
 * the new stack size. */
RF_INLINE int rf_tile_push_children(rf_u32* stack_node, float* stack_t, rf_u32* stack_range, int sp, rf_u32 c,
                                    const float tc[2], rf_u32 range) {
  const int near_s = tc[0] <= tc[1] ? 0 : 1;
  for (int k = 0; k < 2; ++k) {
    const int s = k == 0 ? 1 - near_s : near_s;
    if (tc[s] == RF_FAR) continue;
    stack_node[sp] = c + (rf_u32)s;
    stack_t[sp] = tc[s];
    stack_range[sp] = range;
    ++sp;
  }
  return sp;
}

/* rf_intersect_box for the lanes of lane group j, against each lane's bound
 * over the transform groups in `groups` (rf_group_bound); iz null means a
 * reciprocal z of -1 in every lane (camera space). */
RF_INLINE rf_vi rf_tile_lane_box(const float c0[3], const float c1[3], const rf_vf* ix, const rf_vf* iy,
                                 const rf_vf* iz, const rf_tile_hits* hits, rf_u32 groups, int j) {
  rf_vf bound = (rf_vf)(-1.0f);
  RF_FOR_EACH_GROUP(g, groups) { bound = rf_lanes_max(bound, hits[g].t[j]); }
  return rf_lanes_box(c0, c1, ix[j], iy[j], iz ? iz[j] : (rf_vf)(-1.0f), bound);
}

/* The same test returning each lane's entry distance, RF_FAR where it fails
 * (rf_lanes_box_entry), in tree space (iz given). */
RF_INLINE rf_vf rf_tile_lane_entry(const float c0[3], const float c1[3], const rf_tile_ray* r, const rf_tile_hits* h,
                                   int j) {
  return rf_lanes_box_entry(c0, c1, r->ix[j], r->iy[j], r->iz[j], h->t[j]);
}

/* Narrows [*first, *last] from both ends to the lane groups that have a lane
 * entering the box; 0 when none has. */
RF_INLINE int rf_tile_narrow(const float c0[3], const float c1[3], const rf_vf* ix, const rf_vf* iy, const rf_vf* iz,
                             const rf_tile_hits* hits, rf_u32 groups, int* first, int* last, int stat RF_TSTAT_PARAM) {
  int f = *first, l = *last;
  while (f <= l && !rf_lanes_any(rf_tile_lane_box(c0, c1, ix, iy, iz, hits, groups, f))) ++f;
  RF_TSTAT(stat, f - *first + (f <= l));
  if (f > l) return 0;
  while (l > f && !rf_lanes_any(rf_tile_lane_box(c0, c1, ix, iy, iz, hits, groups, l))) --l;
  RF_TSTAT(stat, *last - l + (l > f));
  *first = f;
  *last = l;
  return 1;
}

/* The lane groups of `groups` (bit j: group j) that may have a lane
 * entering the box c0, c1 (minus the origin). In the bottom level the groups
 * go down as a mask rather than the top level's range: on a dense mesh a
 * node's rays are a few groups spread over the tile, and testing each group
 * keeps only those that enter. Where most of the tile's groups remain, as
 * under the large triangles of an interior, testing each cost more than it
 * saved (2.6x the lane tests on a Lost Empire view), and the mask is
 * narrowed from its ends only, as the range is; a group that fails a box
 * fails every box inside it, so what is dropped is never needed. The
 * limit, three quarters of the groups, took the fewest lane tests on
 * random views of the dragon, Lost Empire, Sponza, the conference room and
 * the car, with 8 lanes and with 16 (dragon: 10% fewer than ends only). */
#ifndef RF_KEEP_EACH_GROUP
#define RF_KEEP_EACH_GROUP (3 * RF_LANE_GROUPS / 4)
#endif
RF_INLINE rf_u32 rf_tile_keep_groups(const float c0[3], const float c1[3], const rf_tile_ray* r, const rf_tile_hits* h,
                                     rf_u32 groups RF_TSTAT_PARAM) {
  /* rf_tile_lane_box of the one group h, whose bound max(-1, t) is t (a
   * lane's t is -1 where it does not answer the group, else at least 0):
   * written out, as the compiler left that loop over the groups a loop
   * (a tenth of this function on the dragon). */
#define RF_GROUP_ENTERS(j) rf_lanes_any(rf_lanes_box(c0, c1, r->ix[j], r->iy[j], r->iz[j], h->t[j]))
  if (popcount(groups) <= RF_KEEP_EACH_GROUP) {
    rf_u32 kept = 0u;
    for (rf_u32 m = groups; m != 0u; m &= m - 1u) {
      const int j = (int)RF_CTZ(m);
      RF_TSTAT(RF_TILE_STAT_BLAS_LANE_BOXES, 1);
      if (RF_GROUP_ENTERS(j)) kept |= 1u << j;
    }
    return kept;
  }
  rf_u32 m = groups;
  for (; m != 0u; m &= m - 1u) {
    RF_TSTAT(RF_TILE_STAT_BLAS_LANE_BOXES, 1);
    if (RF_GROUP_ENTERS((int)RF_CTZ(m))) break;
  }
  while (m & (m - 1u)) { /* two or more left: the highest */
    const int j = 31 - (int)clz(m);
    RF_TSTAT(RF_TILE_STAT_BLAS_LANE_BOXES, 1);
    if (RF_GROUP_ENTERS(j)) break;
    m &= ~(1u << j);
  }
#undef RF_GROUP_ENTERS
  return m;
}

/* A leaf of a bottom-level tree, box c0, c1 (minus the origin): its
 * triangles first_tri .. + count tested on the lane groups of `groups` that
 * have a ray in the box, for the lanes in `entered`. */
RF_INLINE void rf_tile_leaf(const float c0[3], const float c1[3], rf_u32 first_tri, rf_u32 count,
                            const RF_GLOBAL rf_tri* tris, const rf_tile_ray* r, rf_u32 instance_id,
                            const rf_vi* entered, rf_u32 groups, const rf_vf* tmin,
                            rf_tile_hits* h RF_TSTAT_PARAM RF_ALPHA_PARAM) {
  rf_vi lane_in[RF_LANE_GROUPS];
  rf_vf leaf_t[RF_LANE_GROUPS];
  rf_u32 lanes = 0u;
  for (rf_u32 m = groups; m != 0u; m &= m - 1u) {
    const int j = (int)RF_CTZ(m);
    leaf_t[j] = rf_tile_lane_entry(c0, c1, r, h, j);
    lane_in[j] = (leaf_t[j] != (rf_vf)(RF_FAR)) & (entered[j] != (rf_vi)(0)); /* see rf_tile_triangle */
    if (rf_lanes_any(lane_in[j])) lanes |= 1u << j;
    RF_TSTAT(RF_TILE_STAT_BLAS_LANE_BOXES, 1);
  }
  if (lanes == 0u) return;
  RF_TSTAT(RF_TILE_STAT_LEAVES, 1);
  int taken = 0;
  for (rf_u32 k = 0; k < count; ++k) {
    const rf_u32 ti = first_tri + k;
    taken |= rf_tile_triangle(&tris[ti], ti, r, instance_id, lanes, lane_in, leaf_t, tmin, h RF_TSTAT_ARG RF_ALPHA_ARG);
  }
  if (taken) rf_tile_update_tmax(h);
}

/* Entries of the wide traversal's stack: a child slot of a wide node as
 * (node << 2) | slot. Each wide level pushes at most four and pops one, and
 * a wide level descends at least one binary level, so the stack never holds
 * more than three per binary level plus one. */
#define RF_WIDE_STACK_SIZE (3 * RF_STACK_SIZE + 1)

/* rf_interval_box for the four children of a wide node at once, element k
 * child k: the same operations per element, in the same order. */
RF_INLINE float4 rf_tile_interval_box4(const RF_GLOBAL rf_wide_node* n, const rf_tile_ray* r, float tmax) {
  const float4 lx = vload4(0, n->lo_x) - r->o[0], ly = vload4(0, n->lo_y) - r->o[1], lz = vload4(0, n->lo_z) - r->o[2];
  const float4 hx = vload4(0, n->hi_x) - r->o[0], hy = vload4(0, n->hi_y) - r->o[1], hz = vload4(0, n->hi_z) - r->o[2];
#define RF_MIN4(a, b) select((b), (a), (a) < (b))
#define RF_MAX4(a, b) select((b), (a), (a) > (b))
  float4 near_lo[3], far_hi[3];
  const float4 c0[3] = {lx, ly, lz}, c1[3] = {hx, hy, hz};
  for (int a = 0; a < 3; ++a) {
    const float4 p0 = c0[a] * r->lo[a], p1 = c0[a] * r->hi[a], p2 = c1[a] * r->lo[a], p3 = c1[a] * r->hi[a];
    near_lo[a] = RF_MIN4(RF_MIN4(p0, p1), RF_MIN4(p2, p3));
    far_hi[a] = RF_MAX4(RF_MAX4(p0, p1), RF_MAX4(p2, p3));
  }
  const float4 tnear =
      RF_MAX4(RF_MAX4(near_lo[0], near_lo[1]), RF_MAX4(near_lo[2], (float4)(0.0f))) * RF_BOX_NEAR_SCALE;
  const float4 tfar = RF_MIN4(RF_MIN4(far_hi[0], far_hi[1]), far_hi[2]) * RF_BOX_FAR_SCALE;
#undef RF_MIN4
#undef RF_MAX4
  return select(tnear, (float4)(RF_FAR), (tnear > tfar) | (tnear > tmax));
}

/* Pushes the children of wide node w that their whole-tile bounds do not
 * reject, the farthest first so that the nearest is visited next, each with
 * the lane groups `groups` (bit j: group j); returns the new stack size. */
RF_INLINE int rf_tile_push_wide(const RF_GLOBAL rf_wide_node* wide, rf_u32 w, const RF_GLOBAL rf_tri* tris,
                                const rf_tile_ray* r, float tmax, rf_u32 groups, rf_u32* stack_ref, float* stack_t,
                                rf_u32* stack_groups, int sp) {
  const RF_GLOBAL rf_wide_node* n = &wide[w];
  float t4[4];
  vstore4(rf_tile_interval_box4(n, r, tmax), 0, t4);
  float tc[4];
  rf_u32 slot[4];
  int m = 0;
  for (int k = 0; k < 4; ++k) {
    const rf_u32 count = n->count[k];
    if (count == RF_INVALID) break; /* the slots in use come first */
    const float t = t4[k];
    if (t == RF_FAR) continue;
    /* The lines this child reads first when it is popped. */
    const rf_u32 child = n->child[k];
    if (count != 0u) {
      /* Every line of the leaf's triangles: dense meshes' leaves hold 4
       * to 8 (their leaf cost), 4 to 7 lines of 56-byte triangles. */
      rf_prefetch_bytes((const RF_GLOBAL char*)&tris[child], (const RF_GLOBAL char*)&tris[child + count]);
    } else {
      RF_PREFETCH_LINE(&wide[child]);
      RF_PREFETCH_LINE(&wide[child].child[0]);
    }
    int i = m++;
    for (; i > 0 && tc[i - 1] < t; --i) {
      tc[i] = tc[i - 1];
      slot[i] = slot[i - 1];
    }
    tc[i] = t;
    slot[i] = (rf_u32)k;
  }
  for (int i = 0; i < m; ++i) {
    stack_ref[sp] = (w << 2) | slot[i];
    stack_t[sp] = tc[i];
    stack_groups[sp] = groups;
    ++sp;
  }
  return sp;
}

/* Closest hit of every lane's object-space ray in one bottom-level tree
 * (binary root `root`, its children in wide node `wide_root`), for the lanes
 * in `entered` (those whose ray passed the top-level leaf), which lie in the
 * lane groups of `range`. */
RF_INLINE void rf_tile_trace_blas(const RF_GLOBAL rf_node* nodes, const RF_GLOBAL rf_wide_node* wide,
                                  const RF_GLOBAL rf_tri* tris, rf_u32 root, rf_u32 wide_root, const rf_tile_ray* r,
                                  rf_u32 instance_id, const rf_vi* entered, rf_u32 range, const rf_vf* tmin,
                                  rf_tile_hits* h RF_TSTAT_PARAM RF_ALPHA_PARAM) {
  rf_u32 groups = RF_RANGE_MASK(RF_RANGE_FIRST(range), RF_RANGE_LAST(range));
  {
    const RF_GLOBAL rf_node* n = &nodes[root];
    const float c0[3] = {n->bmin[0] - r->o[0], n->bmin[1] - r->o[1], n->bmin[2] - r->o[2]};
    const float c1[3] = {n->bmax[0] - r->o[0], n->bmax[1] - r->o[1], n->bmax[2] - r->o[2]};
    if (rf_interval_box(c0, c1, r->lo, r->hi, h->tmax) == RF_FAR) return;
    RF_TSTAT(RF_TILE_STAT_BLAS_NODES, 1);
    if (wide_root == RF_INVALID) { /* the root is a leaf */
      rf_tile_leaf(c0, c1, n->first, n->meta & RF_NODE_COUNT_MASK, tris, r, instance_id, entered, groups, tmin,
                   h RF_TSTAT_ARG RF_ALPHA_ARG);
      return;
    }
    groups = rf_tile_keep_groups(c0, c1, r, h, groups RF_TSTAT_ARG);
    if (groups == 0u) return;
  }
  rf_u32 stack_ref[RF_WIDE_STACK_SIZE];
  float stack_t[RF_WIDE_STACK_SIZE];
  rf_u32 stack_groups[RF_WIDE_STACK_SIZE];
  int sp = rf_tile_push_wide(wide, wide_root, tris, r, h->tmax, groups, stack_ref, stack_t, stack_groups, 0);
  while (sp > 0) {
    --sp;
    if (stack_t[sp] > h->tmax) continue;
    RF_TSTAT(RF_TILE_STAT_BLAS_NODES, 1);
    const rf_u32 ref = stack_ref[sp];
    const RF_GLOBAL rf_wide_node* p = &wide[ref >> 2];
    const int k = (int)(ref & 3u);
    const float c0[3] = {p->lo_x[k] - r->o[0], p->lo_y[k] - r->o[1], p->lo_z[k] - r->o[2]};
    const float c1[3] = {p->hi_x[k] - r->o[0], p->hi_y[k] - r->o[1], p->hi_z[k] - r->o[2]};
    const rf_u32 groups = stack_groups[sp];
    const rf_u32 count = p->count[k];
    if (count != 0u) {
      rf_tile_leaf(c0, c1, p->child[k], count, tris, r, instance_id, entered, groups, tmin,
                   h RF_TSTAT_ARG RF_ALPHA_ARG);
      continue;
    }
    /* Interior: go on with the lane groups that enter the box. */
    const rf_u32 kept = rf_tile_keep_groups(c0, c1, r, h, groups RF_TSTAT_ARG);
    if (kept != 0u)
      sp = rf_tile_push_wide(wide, p->child[k], tris, r, h->tmax, kept, stack_ref, stack_t, stack_groups, sp);
  }
}

/* The skipping bound of a top-level node for the tile: the largest tmax of
 * the groups below it that the tile answers (rf_group_bound over the whole
 * tile). */
RF_INLINE float rf_tile_group_bound(rf_u32 groups, const rf_tile_hits* hits) {
  float bound = -1.0f;
  RF_FOR_EACH_GROUP(g, groups) { bound = rf_maxf(bound, hits[g].tmax); }
  return bound;
}

/* Object-space set-ups kept per tile (rf_tile_to_object), one per group:
 * each view's and mirror's copy of an instance has a transform of its own,
 * and the copies of one instance are met together (their boxes overlap in
 * camera space), so sharing slots made them evict each other (3.3x the
 * set-ups per view on Sponza, 8 views folded xy). 9 KiB each. */
#define RF_TILE_SETUPS RF_MAX_GROUPS

/* Closest hit per group of every lane through the top-level tree;
 * tile_groups: the groups some lane answers (the others' hits are not
 * set). */
RF_INLINE void rf_tile_trace_tlas(const RF_GLOBAL rf_node* nodes, const RF_GLOBAL rf_wide_node* wide,
                                  const RF_GLOBAL rf_tri* tris, const RF_GLOBAL rf_instance* instances,
                                  rf_u32 tlas_root, const rf_tile_camera* cam, const rf_tile_query* q,
                                  rf_u32 tile_groups, rf_tile_ray* ro,
                                  rf_tile_hits* hits RF_TSTAT_PARAM RF_ALPHA_PARAM) {
  /* Camera rays start at the trace-space origin; boxes less +0 keep their
   * bits, as the scalar code's box minus its origin does. */
  const float o0 = q ? q->o[0] : 0.0f, o1 = q ? q->o[1] : 0.0f, o2 = q ? q->o[2] : 0.0f;
  const rf_vf* iz = q ? q->iz : 0;
  const rf_vf* tmin = q ? q->tmin : 0;
  rf_u32 stack_node[RF_STACK_SIZE];
  float stack_t[RF_STACK_SIZE];
  rf_u32 stack_range[RF_STACK_SIZE];
  int sp = 0;
  {
    const RF_GLOBAL rf_node* n = &nodes[tlas_root];
    const float c0[3] = {n->bmin[0] - o0, n->bmin[1] - o1, n->bmin[2] - o2};
    const float c1[3] = {n->bmax[0] - o0, n->bmax[1] - o1, n->bmax[2] - o2};
    const float tn = rf_interval_box(c0, c1, cam->lo, cam->hi, rf_tile_group_bound(n->meta & tile_groups, hits));
    if (tn == RF_FAR) return;
    stack_node[0] = tlas_root;
    stack_t[0] = tn;
    stack_range[0] = RF_RANGE(0, RF_LANE_GROUPS - 1);
    sp = 1;
  }
  while (sp > 0) {
    --sp;
    const RF_GLOBAL rf_node* n = &nodes[stack_node[sp]];
    const rf_u32 groups = n->meta & tile_groups;
    if (stack_t[sp] > rf_tile_group_bound(groups, hits)) continue;
    RF_TSTAT(RF_TILE_STAT_TLAS_NODES, 1);
    const rf_u32 count = n->first >> RF_TLAS_COUNT_SHIFT;
    const rf_u32 first_item = n->first & RF_TLAS_INDEX_MASK;
    const float c0[3] = {n->bmin[0] - o0, n->bmin[1] - o1, n->bmin[2] - o2};
    const float c1[3] = {n->bmax[0] - o0, n->bmax[1] - o1, n->bmax[2] - o2};
    int first = RF_RANGE_FIRST(stack_range[sp]), last = RF_RANGE_LAST(stack_range[sp]);
    if (!rf_tile_narrow(c0, c1, cam->ix, cam->iy, iz, hits, groups, &first, &last,
                        RF_TILE_STAT_TLAS_LANE_BOXES RF_TSTAT_ARG))
      continue;
    const rf_u32 range = RF_RANGE(first, last);
    if (count != 0) {
      /* The lanes whose own test enters this leaf; the others must not take
       * hits below it (see the top of this file). */
      rf_vi entered[RF_LANE_GROUPS];
      for (int j = first; j <= last; ++j) entered[j] = rf_tile_lane_box(c0, c1, cam->ix, cam->iy, iz, hits, groups, j);
      RF_TSTAT(RF_TILE_STAT_TLAS_LANE_BOXES, last - first + 1);
      for (rf_u32 k = 0; k < count; ++k) {
        const RF_GLOBAL rf_instance* inst = &instances[first_item + k];
        const rf_u32 g = inst->group;
        if (((tile_groups >> g) & 1u) == 0u) continue;
        rf_tile_hits* h = &hits[g];
        if (h->tmax < 0.0f) continue; /* no lane answers this group */
        RF_TSTAT(RF_TILE_STAT_INSTANCES, 1);
        rf_tile_ray* r = &ro[g];
        rf_tile_to_object(r, inst->tree_from_trace, cam, q RF_TSTAT_ARG);
        rf_tile_trace_blas(nodes, wide, tris, inst->blas_root, inst->wide_root, r, inst->instance_id, entered, range,
                           tmin, h RF_TSTAT_ARG RF_ALPHA_ARG);
      }
      continue;
    }
    const rf_u32 c = first_item;
    float tc[2];
    for (int s = 0; s < 2; ++s) {
      const RF_GLOBAL rf_node* ch = &nodes[c + s];
      const float d0[3] = {ch->bmin[0] - o0, ch->bmin[1] - o1, ch->bmin[2] - o2};
      const float d1[3] = {ch->bmax[0] - o0, ch->bmax[1] - o1, ch->bmax[2] - o2};
      tc[s] = rf_interval_box(d0, d1, cam->lo, cam->hi, rf_tile_group_bound(ch->meta & tile_groups, hits));
    }
    sp = rf_tile_push_children(stack_node, stack_t, stack_range, sp, c, tc, range);
  }
}

/* The triangles of lane group j's hits, for the exact depth: their
 * vertices (lane 0's where a lane missed; its results are not used) and
 * each lane's rf_depth_key. One load for the whole vector when its lanes
 * agree, as on large triangles, else a gather. (The normals,
 * rf_tile_lane_normals, read the triangles' stored cross products instead:
 * sharing this gather with the float depth's normals, with its keys,
 * slowed those frames by a tenth on Sponza.) */
typedef struct {
  rf_vf v[9]; /* v0, v1, v2 by coordinate */
  rf_vu key;
  int one_tri; /* every lane that hit has lane 0's triangle */
  int one_key; /* every lane that hit has lane 0's key */
  rf_u32 key0;
  float v0[9]; /* lane 0's vertices */
} rf_tile_lane_tris;

RF_INLINE void rf_tile_gather_tris(const rf_tile_hits* h, int j, rf_vi hit, const RF_GLOBAL rf_tri* tris,
                                   rf_tile_lane_tris* lt) {
  float gv[9][RF_LANES];
  rf_u32 ginst[RF_LANES];
  const rf_u32* tri_idx = (const rf_u32*)&h->tri[j];
  const rf_u32* inst_idx = (const rf_u32*)&h->instance[j];
  const rf_vi missed = ~hit;
  const int one_tri = !rf_lanes_any(missed | (h->tri[j] != (rf_vu)(tri_idx[0])));
  for (int l = 0; l < RF_LANES; ++l) {
    if (one_tri && l > 0) break;
    const int lane_hit = inst_idx[l] != RF_INVALID;
    const RF_GLOBAL rf_tri* tri = &tris[lane_hit ? tri_idx[l] : 0u];
    for (int k = 0; k < 3; ++k) {
      gv[k][l] = tri->v0[k];
      gv[3 + k][l] = tri->v1[k];
      gv[6 + k][l] = tri->v2[k];
    }
    ginst[l] = tri->inst;
  }
  for (int k = 0; k < 9; ++k) {
    lt->v[k] = one_tri ? (rf_vf)(gv[k][0]) : *(const rf_vf*)gv[k];
    lt->v0[k] = gv[k][0];
  }
  lt->one_tri = one_tri;
  /* rf_depth_key per lane: lanes on one triangle index may still hit
   * different instances of its mesh. */
  const rf_vu tri_inst = one_tri ? (rf_vu)(ginst[0]) : rf_lanes_load_u(0, ginst);
  lt->key = select((rf_vu)(0u), h->instance[j] - tri_inst, hit);
  lt->key0 = ((const rf_u32*)&lt->key)[0];
  lt->one_key = !rf_lanes_any(missed | (lt->key != (rf_vu)(lt->key0)));
}

/* rf_geometric_normal's last steps on lanes: the world-space normal w (the
 * normal matrix times the cross product of the edges) scaled by its largest
 * component and made unit length, 0 where a lane missed (hit: the lanes
 * that did) or its triangle is degenerate. */
RF_INLINE void rf_tile_unit_normals(const rf_vf* w, rf_vi hit, rf_vf* nx, rf_vf* ny, rf_vf* nz) {
  rf_vf wx = w[0], wy = w[1], wz = w[2];
  const rf_vf big = rf_lanes_max(rf_lanes_max(fabs(wx), fabs(wy)), fabs(wz));
  const rf_vi degenerate = ~(big > (rf_vf)(0.0f));
  wx = wx / big;
  wy = wy / big;
  wz = wz / big;
  const rf_vf len = sqrt(wx * wx + wy * wy + wz * wz);
  const rf_vi zero = degenerate | ~hit;
  *nx = select(wx / len, (rf_vf)(0.0f), zero);
  *ny = select(wy / len, (rf_vf)(0.0f), zero);
  *nz = select(wz / len, (rf_vf)(0.0f), zero);
}

/* The last world-space normal rf_tile_lane_normals made for a whole lane
 * group: the lane groups in a row on one large triangle share it. */
typedef struct {
  rf_u32 tri, instance; /* tri RF_INVALID: empty */
  float n[3];
} rf_tile_normal_cache;

/* rf_geometric_normal for the lanes of lane group j that hit (hit: their
 * mask), 0 where a lane missed. Where every lane hit one triangle of one
 * instance, as on large triangles, the scalar rf_geometric_normal once
 * (kept in `cache` for the next such groups): a lane's operations are its
 * operations, so every lane gets the same bits, without eight lanes of
 * divisions and a square root for one value. Elsewhere each lane's stored
 * cross product (rf_tri.n, the scalar code's input) and normal matrix
 * (lane 0's where a lane missed; its result is replaced), one load for the
 * whole vector where the lanes agree, else a gather. */
RF_INLINE void rf_tile_lane_normals(const rf_tile_hits* h, int j, rf_vi hit, const RF_GLOBAL rf_tri* tris,
                                    const RF_GLOBAL rf_normal_xform* normal_xforms, rf_tile_normal_cache* cache,
                                    rf_vf* nx, rf_vf* ny, rf_vf* nz) {
  const rf_u32* tri_idx = (const rf_u32*)&h->tri[j];
  const rf_u32* inst_idx = (const rf_u32*)&h->instance[j];
  const rf_vi missed = ~hit;
  const int one_tri = !rf_lanes_any(missed | (h->tri[j] != (rf_vu)(tri_idx[0])));
  const int one_inst = !rf_lanes_any(missed | (h->instance[j] != (rf_vu)(inst_idx[0])));
  if (one_tri && one_inst) {
    if (cache->tri != tri_idx[0] || cache->instance != inst_idx[0]) {
      rf_geometric_normal(&tris[tri_idx[0]], &normal_xforms[inst_idx[0]], cache->n);
      cache->tri = tri_idx[0];
      cache->instance = inst_idx[0];
    }
    *nx = (rf_vf)(cache->n[0]);
    *ny = (rf_vf)(cache->n[1]);
    *nz = (rf_vf)(cache->n[2]);
    return;
  }
  float gc[3][RF_LANES], gm[9][RF_LANES];
  for (int l = 0; l < RF_LANES; ++l) {
    const int lane_hit = inst_idx[l] != RF_INVALID;
    if (!one_tri || l == 0) {
      const RF_GLOBAL rf_tri* tri = &tris[lane_hit ? tri_idx[l] : 0u];
      for (int k = 0; k < 3; ++k) gc[k][l] = tri->n[k];
    }
    if (!one_inst || l == 0) {
      const RF_GLOBAL float* m = normal_xforms[lane_hit ? inst_idx[l] : 0u].m;
      for (int k = 0; k < 9; ++k) gm[k][l] = m[k];
    }
  }
  /* Each value read where it is used: gathering the vectors into arrays
   * first took a fifth more instructions here (callgrind, Sponza). */
#define RF_G(a, k) (one_##a ? (rf_vf)(a[k][0]) : *(const rf_vf*)a[k])
#define one_gc one_tri
#define one_gm one_inst
  const rf_vf w[3] = {RF_G(gm, 0) * RF_G(gc, 0) + RF_G(gm, 1) * RF_G(gc, 1) + RF_G(gm, 2) * RF_G(gc, 2),
                      RF_G(gm, 3) * RF_G(gc, 0) + RF_G(gm, 4) * RF_G(gc, 1) + RF_G(gm, 5) * RF_G(gc, 2),
                      RF_G(gm, 6) * RF_G(gc, 0) + RF_G(gm, 7) * RF_G(gc, 1) + RF_G(gm, 8) * RF_G(gc, 2)};
#undef RF_G
#undef one_gc
#undef one_gm
  rf_tile_unit_normals(w, hit, nx, ny, nz);
}

/* rf_depth.h's arithmetic on lanes: each lane's operations are the scalar
 * code's. */
RF_DEPTH_DEFINE(rf_vf, v)

/* The plane part of the last lane group whose lanes shared one triangle and
 * tree: large triangles cover many lane groups in a row. */
typedef struct {
  rf_u32 tri, key, view; /* tri RF_INVALID: empty */
  float pl[8];
} rf_tile_plane_cache;

/* The exact depth's per-pixel part that does not depend on the hit, for the
 * tile's rays in one view: per lane the offsets (ix, iy) of its ray's own
 * pixel (unmirrored) and rf_depth_length's pair, made for lane group j when
 * it first needs them (bit j of `made`). A mirror partner's offsets are the
 * negated ones, exactly (xpair = -kx0, ypair = ky0: rf_types.h), and its
 * length the same bits: the camera entry has no offset along an axis that
 * folds (can_fold_columns, can_fold_rows), so the length is a function of
 * |ix| and |iy| there. A ray's two or four pixels make it once: exact-depth
 * frames folded xy 1.14x to 1.19x faster on the interiors' random views,
 * where every pixel pays the length (docs/results.md). */
typedef struct {
  rf_u32 view; /* RF_INVALID: none made */
  rf_u32 made; /* bit j: lane group j's below are made */
  rf_vf ix[RF_LANE_GROUPS], iy[RF_LANE_GROUPS];
  rf_vf len_h[RF_LANE_GROUPS], len_l[RF_LANE_GROUPS];
} rf_tile_pixel_rays;

/* rf_depth_length of the lanes of group j, ix and iy their pixel offsets,
 * for the view's camera entry cm. */
RF_INLINE rf_vf rf_tile_lane_lengths(const RF_GLOBAL float* cm_g, const rf_camera* cam, rf_vf ix, rf_vf iy,
                                     rf_vf* len_l) {
  rf_vf cm[24];
  for (int k = 0; k < 24; ++k) cm[k] = (rf_vf)(cm_g[k]);
  return rf_depth_length_v(cm, ix, iy, cam->ortho, (cam->write_flags & RF_WRITE_PLANAR_DEPTH) != 0u, len_l);
}

/* rf_pixel_depth for the lanes of lane group j that hit, in vectors: for
 * group g's view and pixels, the depth of rf_depth.h where it is
 * plausible, else z. */
RF_INLINE rf_vf rf_tile_lane_depths(const RF_GLOBAL rf_u32* rays, rf_u32 begin, rf_u32 count, int j,
                                    const rf_camera* cam, rf_u32 g,
                                    const rf_tile_hits* h, rf_vi hit, const rf_tile_lane_tris* lt,
                                    const rf_depth_table* dt, float depth_scale, rf_tile_plane_cache* cache,
                                    rf_tile_pixel_rays* pr, rf_vf z) {
  const rf_u32 view = g >> cam->group_shift;
  const rf_u32 mirror = rf_group_mirror(g, cam);
  const RF_GLOBAL rf_depth_xform* cam_xf = &dt->xforms[(size_t)view * (dt->instances + 1u)];
  if (pr->view != view) {
    pr->view = view;
    pr->made = 0u;
  }
  if (((pr->made >> j) & 1u) == 0u) {
    /* Each lane's pixel offsets 2 x + kx0 and ky0 - 2 y (rays
     * j * RF_LANES + l of the tile), exact in float. Decoded here rather
     * than kept with the tile's rays, which the float depth's frames would
     * pay for. */
    float gix[RF_LANES], giy[RF_LANES];
    for (int l = 0; l < RF_LANES; ++l) {
      const rf_u32 r = (rf_u32)(j * RF_LANES + l);
      const rf_u32 entry = rays[begin + (r < count ? r : count - 1u)];
      const rf_i32 x = (rf_i32)(entry & RF_RAY_COORD_MASK);
      const rf_i32 y = (rf_i32)((entry >> RF_RAY_COORD_BITS) & RF_RAY_COORD_MASK);
      gix[l] = (float)(2 * x + cam->kx0);
      giy[l] = (float)(cam->ky0 - 2 * y);
    }
    pr->ix[j] = *(const rf_vf*)gix;
    pr->iy[j] = *(const rf_vf*)giy;
    pr->len_h[j] = rf_tile_lane_lengths(cam_xf->m, cam, pr->ix[j], pr->iy[j], &pr->len_l[j]);
    pr->made |= 1u << j;
  }
  const rf_vf ix = (mirror & 1u) ? -pr->ix[j] : pr->ix[j];
  const rf_vf iy = (mirror & 2u) ? -pr->iy[j] : pr->iy[j];
  const rf_vf len_h = pr->len_h[j], len_l = pr->len_l[j];
  /* The plane part: once for the vector where its lanes share the
   * triangle and the tree (large triangles), else per lane, each lane's
   * transform gathered unless the lanes share a tree. */
  rf_vf pl[8];
  if (lt->one_tri && lt->one_key) {
    const rf_u32 tri0 = ((const rf_u32*)&h->tri[j])[0];
    if (cache->tri != tri0 || cache->key != lt->key0 || cache->view != view) {
      float v0[9], m0[24];
      const RF_GLOBAL float* mk = cam_xf[1u + lt->key0].m;
      for (int k = 0; k < 9; ++k) v0[k] = lt->v0[k];
      for (int k = 0; k < 24; ++k) m0[k] = mk[k];
      rf_depth_plane_f(v0, m0, cache->pl);
      cache->tri = tri0;
      cache->key = lt->key0;
      cache->view = view;
    }
    for (int k = 0; k < 8; ++k) pl[k] = (rf_vf)(cache->pl[k]);
  } else {
    rf_vf m[24];
    if (lt->one_key) {
      const RF_GLOBAL float* mk = cam_xf[1u + lt->key0].m;
      for (int k = 0; k < 24; ++k) m[k] = (rf_vf)(mk[k]);
    } else {
      float gm[24][RF_LANES];
      const rf_u32* keys = (const rf_u32*)&lt->key;
      for (int l = 0; l < RF_LANES; ++l) {
        const RF_GLOBAL float* mk = cam_xf[1u + keys[l]].m;
        for (int k = 0; k < 24; ++k) gm[k][l] = mk[k];
      }
      for (int k = 0; k < 24; ++k) m[k] = *(const rf_vf*)gm[k];
    }
    rf_depth_plane_v(lt->v, m, pl);
  }
  const rf_vf d = rf_depth_finish_v(pl, len_h, len_l, ix, iy, cam->ortho);
  /* rf_depth_plausible on lanes. */
  const rf_vf e = d * depth_scale;
  return select(z, e, hit & (e > (rf_vf)(0.0f)) & (e < (rf_vf)(RF_FAR)) & (fabs(e - z) <= z * 0x1p-8f));
}

/* The exact depth of lane group j, and its normals unless normal_xforms is
 * null (rf_tile_lane_normals, as the float depth's). Not inlined where the
 * compiler allows: inlined, its code slowed the float depth's write stage,
 * which never runs it. */
RF_NOINLINE void rf_tile_exact_lane_group(const RF_GLOBAL rf_u32* rays, rf_u32 begin, rf_u32 count, int j,
                                          const rf_camera* cam, rf_u32 g, const rf_tile_hits* h, rf_vi hit,
                                          const rf_depth_table* depths, float depth_scale,
                                          rf_tile_plane_cache* plane_cache, const RF_GLOBAL rf_tri* tris,
                                          const RF_GLOBAL rf_normal_xform* normal_xforms,
                                          rf_tile_normal_cache* normal_cache, rf_vf* z, rf_vf* nx, rf_vf* ny,
                                          rf_vf* nz, rf_tile_pixel_rays* pixel_rays) {
  rf_tile_lane_tris lt;
  rf_tile_gather_tris(h, j, hit, tris, &lt);
  *z = rf_tile_lane_depths(rays, begin, count, j, cam, g, h, hit, &lt, depths, depth_scale, plane_cache, pixel_rays,
                           *z);
  if (normal_xforms) rf_tile_lane_normals(h, j, hit, tris, normal_xforms, normal_cache, nx, ny, nz);
}

/* Puts one lane's answer, w (rf_pixel_hit's eight words), at index i of
 * `out`: into its hits as one 32-byte store, or into its planes. As
 * integers, so that the ids, NaN patterns as floats, never pass a float
 * register. */
RF_INLINE void rf_tile_put(const rf_answers* out, size_t i, uint8 w) {
  if (out->hits) {
    vstore8(w, 0, (RF_GLOBAL rf_u32*)&out->hits[i]);
    return;
  }
  if (out->z) ((RF_GLOBAL rf_u32*)out->z)[i] = w.s0;
  if (out->normal) vstore3(w.s123, i, (RF_GLOBAL rf_u32*)out->normal);
  if (out->uv) vstore2(w.s45, i, (RF_GLOBAL rf_u32*)out->uv);
  if (out->instance) out->instance[i] = w.s6;
  if (out->primitive) out->primitive[i] = w.s7;
}

/* Eight lanes' answers, w0 .. w7 (word w of rf_pixel_hit, lane k in
 * element k), as eight 32-byte records, r0 .. r7 (lane k's in rk): an 8x8
 * transpose in three rounds of shuffles, where putting each lane's words
 * one by one took a dozen inserts a pixel. */
#define RF_UNPACK_LO(a, b) ((uint8)((a).s0, (b).s0, (a).s1, (b).s1, (a).s4, (b).s4, (a).s5, (b).s5))
#define RF_UNPACK_HI(a, b) ((uint8)((a).s2, (b).s2, (a).s3, (b).s3, (a).s6, (b).s6, (a).s7, (b).s7))
#define RF_UNPACK2_LO(a, b) ((uint8)((a).s0, (a).s1, (b).s0, (b).s1, (a).s4, (a).s5, (b).s4, (b).s5))
#define RF_UNPACK2_HI(a, b) ((uint8)((a).s2, (a).s3, (b).s2, (b).s3, (a).s6, (a).s7, (b).s6, (b).s7))
#define RF_TRANSPOSE8(w0, w1, w2, w3, w4, w5, w6, w7, r0, r1, r2, r3, r4, r5, r6, r7)                      \
  do {                                                                                                    \
    const uint8 t0_ = RF_UNPACK_LO(w0, w1), t1_ = RF_UNPACK_HI(w0, w1);                                   \
    const uint8 t2_ = RF_UNPACK_LO(w2, w3), t3_ = RF_UNPACK_HI(w2, w3);                                   \
    const uint8 t4_ = RF_UNPACK_LO(w4, w5), t5_ = RF_UNPACK_HI(w4, w5);                                   \
    const uint8 t6_ = RF_UNPACK_LO(w6, w7), t7_ = RF_UNPACK_HI(w6, w7);                                   \
    const uint8 u0_ = RF_UNPACK2_LO(t0_, t2_), u1_ = RF_UNPACK2_HI(t0_, t2_);                             \
    const uint8 u2_ = RF_UNPACK2_LO(t1_, t3_), u3_ = RF_UNPACK2_HI(t1_, t3_);                             \
    const uint8 u4_ = RF_UNPACK2_LO(t4_, t6_), u5_ = RF_UNPACK2_HI(t4_, t6_);                             \
    const uint8 u6_ = RF_UNPACK2_LO(t5_, t7_), u7_ = RF_UNPACK2_HI(t5_, t7_);                             \
    r0 = (uint8)(u0_.lo, u4_.lo);                                                                         \
    r1 = (uint8)(u1_.lo, u5_.lo);                                                                         \
    r2 = (uint8)(u2_.lo, u6_.lo);                                                                         \
    r3 = (uint8)(u3_.lo, u7_.lo);                                                                         \
    r4 = (uint8)(u0_.hi, u4_.hi);                                                                         \
    r5 = (uint8)(u1_.hi, u5_.hi);                                                                         \
    r6 = (uint8)(u2_.hi, u6_.hi);                                                                         \
    r7 = (uint8)(u3_.hi, u7_.hi);                                                                         \
  } while (0)

/* Half b (lanes 8b .. 8b + 7) of a lane vector as a uint8 of its bits. */
#if RF_LANES == 8
#define RF_EIGHT(v, b) as_uint8(v)
#else
#define RF_EIGHT(v, b) ((b) ? as_uint8((v).hi) : as_uint8((v).lo))
#endif

/* Writes the answers of lane group j to group g when its lanes are one whole
 * block of the ray list (fold/ray_list.h: lane k at (x0 + k % 4, y0 + k / 4))
 * and every lane answers g: a few vector stores a row of four pixels
 * (reversed where g mirrors the columns) instead of a decode and a store a
 * lane. Returns 0, having written nothing, otherwise (tile edges, partial
 * quads beside a fold line, lanes of other groups). Each word is the
 * per-lane path's, ids and NaN patterns as integers. */
RF_INLINE_ALWAYS int rf_tile_write_block(const RF_GLOBAL rf_u32* rays, rf_u32 begin, rf_u32 count, int j,
                                         const rf_camera* cam, const rf_u32* lane_groups, rf_u32 g, rf_u32 mirror,
                                         size_t view_base, const rf_vf* z, const rf_vf* nx, const rf_vf* ny,
                                         const rf_vf* nz, const rf_tile_hits* h, const rf_answers* out) {
  const rf_u32 l0 = (rf_u32)j * RF_LANES;
  if (l0 + RF_LANES > count) return 0;
  const rf_vu e = rf_lanes_load_u(0, rays + begin + l0);
  const rf_vu answers_g = (rf_lanes_load_u(0, lane_groups + l0) >> g) & 1u;
  const rf_vu x = e & RF_RAY_COORD_MASK, y = (e >> RF_RAY_COORD_BITS) & RF_RAY_COORD_MASK;
#if RF_LANES == 8
  const rf_vu k = (rf_vu)(0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u);
#else
  const rf_vu k = (rf_vu)(0u, 1u, 2u, 3u, 4u, 5u, 6u, 7u, 8u, 9u, 10u, 11u, 12u, 13u, 14u, 15u);
#endif
  const rf_u32 x0 = x.s0, y0 = y.s0;
  if (rf_lanes_any((answers_g == (rf_vu)(0u)) | (x != x0 + (k & 3u)) | (y != y0 + (k >> 2u)))) return 0;
  const int flip_x = (mirror & 1u) != 0u;
  const rf_i32 px0 = flip_x ? cam->xpair - (rf_i32)x0 - 3 : (rf_i32)x0;
  const rf_vi hit = h->instance[j] != (rf_vu)(RF_INVALID);
  const rf_vu u = select((rf_vu)(0u), rf_lanes_as_vu(h->u[j]), hit); /* 0.0f's bits on a miss */
  const rf_vu v = select((rf_vu)(0u), rf_lanes_as_vu(h->v[j]), hit);
  const rf_vu prim = select((rf_vu)(RF_INVALID), h->prim[j], hit);
  /* The pixel index of lane c (0 .. 3) of row r. */
#define RF_PIXEL(r, c)                                                                          \
  (view_base + (size_t)(((mirror & 2u) ? cam->ypair - ((rf_i32)y0 + (r)) : (rf_i32)y0 + (r)) * \
                            cam->width +                                                         \
                        px0 + (flip_x ? 3 - (c) : (c))))
  if (out->hits) {
    /* A whole record at pixel i as a streaming store where the hits are
     * 32-byte aligned (the host's frame buffers are): each row of four
     * pixels fills two whole lines, which a plain store reads from memory
     * first. On random views of all seven scenes, two seeds, in one process
     * (AVX-512 Xeon): 1.00x to 1.04x at each scene's best fold, 1.01x to
     * 1.09x folded xy (four mirrored writes a ray). Into planes the same
     * was 0.93x (rows of 16 bytes in five planes; written a strip of four
     * blocks at a time, plane by plane, 0.88x), so planes keep plain
     * stores. */
#if defined(RF_CLANG_BUILTINS)
    const int stream = ((size_t)out->hits & 31u) == 0u;
#define RF_HIT_STORE(w, i)                                                      \
  (stream ? __builtin_nontemporal_store((w), (RF_GLOBAL uint8*)out->hits + (i)) \
          : vstore8((w), (i), (RF_GLOBAL rf_u32*)out->hits))
#else
#define RF_HIT_STORE(w, i) vstore8((w), (i), (RF_GLOBAL rf_u32*)out->hits)
#endif
    for (int b = 0; b < RF_LANES / 8; ++b) {
      uint8 r0, r1, r2, r3, r4, r5, r6, r7;
      RF_TRANSPOSE8(RF_EIGHT(z[j], b), RF_EIGHT(nx[j], b), RF_EIGHT(ny[j], b), RF_EIGHT(nz[j], b), RF_EIGHT(u, b),
                    RF_EIGHT(v, b), RF_EIGHT(h->instance[j], b), RF_EIGHT(prim, b), r0, r1, r2, r3, r4, r5, r6, r7);
      RF_HIT_STORE(r0, RF_PIXEL(2 * b, 0));
      RF_HIT_STORE(r1, RF_PIXEL(2 * b, 1));
      RF_HIT_STORE(r2, RF_PIXEL(2 * b, 2));
      RF_HIT_STORE(r3, RF_PIXEL(2 * b, 3));
      RF_HIT_STORE(r4, RF_PIXEL(2 * b + 1, 0));
      RF_HIT_STORE(r5, RF_PIXEL(2 * b + 1, 1));
      RF_HIT_STORE(r6, RF_PIXEL(2 * b + 1, 2));
      RF_HIT_STORE(r7, RF_PIXEL(2 * b + 1, 3));
    }
#undef RF_HIT_STORE
    return 1;
  }
  const rf_u32* zs = (const rf_u32*)&z[j];
  const rf_u32* xs = (const rf_u32*)&nx[j];
  const rf_u32* ys = (const rf_u32*)&ny[j];
  const rf_u32* ws = (const rf_u32*)&nz[j];
  const rf_u32* is = (const rf_u32*)&h->instance[j];
  const rf_u32* us = (const rf_u32*)&u;
  const rf_u32* vs = (const rf_u32*)&v;
  const rf_u32* ps = (const rf_u32*)&prim;
  /* Row r's four words of a lane vector, left to right in the image. */
#define RF_ROW(a, r) (flip_x ? vload4(r, a).s3210 : vload4(r, a))
  for (int r = 0; r < RF_LANES / 4; ++r) {
    const size_t i = RF_PIXEL(r, flip_x ? 3 : 0);
    if (out->z) vstore4(RF_ROW(zs, r), 0, (RF_GLOBAL rf_u32*)out->z + i);
    if (out->normal) {
      const uint4 a = RF_ROW(xs, r), b = RF_ROW(ys, r), c = RF_ROW(ws, r);
      RF_GLOBAL rf_u32* n = (RF_GLOBAL rf_u32*)out->normal + 3 * i;
      vstore4((uint4)(a.s0, b.s0, c.s0, a.s1), 0, n);
      vstore4((uint4)(b.s1, c.s1, a.s2, b.s2), 0, n + 4);
      vstore4((uint4)(c.s2, a.s3, b.s3, c.s3), 0, n + 8);
    }
    if (out->uv) {
      const uint4 a = RF_ROW(us, r), b = RF_ROW(vs, r);
      vstore8((uint8)(a.s0, b.s0, a.s1, b.s1, a.s2, b.s2, a.s3, b.s3), 0, (RF_GLOBAL rf_u32*)out->uv + 2 * i);
    }
    if (out->instance) vstore4(RF_ROW(is, r), 0, out->instance + i);
    if (out->primitive) vstore4(RF_ROW(ps, r), 0, out->primitive + i);
  }
#undef RF_ROW
#undef RF_PIXEL
  return 1;
}

/* rf_write_pixel for every lane of the tile that answers group g, lane by
 * lane: the normal (rf_geometric_normal) and depth in vectors, with the
 * scalar code's operations per lane, then one pixel store per lane. The
 * per-pixel normal, with its divisions and square root, costs as much as
 * the traversal when done one pixel at a time. */
RF_INLINE void rf_tile_write_group(const RF_GLOBAL rf_u32* rays, rf_u32 begin, rf_u32 count, const rf_camera* cam,
                                   const rf_u32* lane_groups, const rf_tile_camera* tc, const rf_tile_hits* h, rf_u32 g,
                                   float depth_scale, const rf_depth_table* depths, const RF_GLOBAL rf_tri* tris,
                                   const RF_GLOBAL rf_normal_xform* normal_xforms, rf_tile_pixel_rays* pixel_rays,
                                   const rf_answers* out) {
  rf_vf z[RF_LANE_GROUPS], nx[RF_LANE_GROUPS], ny[RF_LANE_GROUPS], nz[RF_LANE_GROUPS];
  const int exact_depth = (cam->write_flags & RF_WRITE_EXACT_DEPTH) != 0u;
  rf_tile_plane_cache plane_cache;
  plane_cache.tri = RF_INVALID;
  rf_tile_normal_cache normal_cache;
  normal_cache.tri = RF_INVALID;
  for (int j = 0; j < RF_LANE_GROUPS; ++j) {
    const rf_vi hit = h->instance[j] != (rf_vu)(RF_INVALID);
    const rf_vf dz = (rf_vf)(-1.0f);
    const rf_vf len_d = (cam->write_flags & RF_WRITE_PLANAR_DEPTH)
                            ? (rf_vf)(1.0f)
                            : sqrt(tc->dx[j] * tc->dx[j] + tc->dy[j] * tc->dy[j] + dz * dz);
    /* Planar: t * depth_scale, as the scalar code (t * 1 is t). */
    z[j] = select((rf_vf)(RF_INF), (h->t[j] * len_d) * depth_scale, hit);
    const int normals = (cam->write_flags & RF_WRITE_NO_NORMALS) == 0u;
    nx[j] = ny[j] = nz[j] = (rf_vf)(0.0f);
    if (!rf_lanes_any(hit)) continue;
    if (exact_depth) {
      rf_tile_exact_lane_group(rays, begin, count, j, cam, g, h, hit, depths, depth_scale, &plane_cache, tris,
                               normals ? normal_xforms : 0, &normal_cache, &z[j], &nx[j], &ny[j], &nz[j],
                               pixel_rays);
    } else if (normals) {
      rf_tile_lane_normals(h, j, hit, tris, normal_xforms, &normal_cache, &nx[j], &ny[j], &nz[j]);
    }
  }
  const float* zs = (const float*)z;
  const float* xs = (const float*)nx;
  const float* ys = (const float*)ny;
  const float* ws = (const float*)nz;
  const float* us = (const float*)h->u;
  const float* vs = (const float*)h->v;
  const rf_u32* is = (const rf_u32*)h->instance;
  const rf_u32* ps = (const rf_u32*)h->prim;
  const rf_u32 mirror = rf_group_mirror(g, cam);
  const size_t view_base = rf_group_view_base(g, cam);
  for (rf_u32 l = 0; l < count; ++l) {
    if (l % RF_LANES == 0u && rf_tile_write_block(rays, begin, count, (int)(l / RF_LANES), cam, lane_groups, g,
                                                  mirror, view_base, z, nx, ny, nz, h, out)) {
      l += RF_LANES - 1u;
      continue;
    }
    if (((lane_groups[l] >> g) & 1u) == 0u) continue;
    const rf_u32 entry = rays[begin + l];
    const rf_i32 x = (rf_i32)(entry & RF_RAY_COORD_MASK);
    const rf_i32 y = (rf_i32)((entry >> RF_RAY_COORD_BITS) & RF_RAY_COORD_MASK);
    const rf_i32 px = (mirror & 1u) ? cam->xpair - x : x;
    const rf_i32 py = (mirror & 2u) ? cam->ypair - y : y;
    const int hit = is[l] != RF_INVALID;
    const uint8 px_hit =
        (uint8)(as_uint(zs[l]), as_uint(xs[l]), as_uint(ys[l]), as_uint(ws[l]), as_uint(hit ? us[l] : 0.0f),
                as_uint(hit ? vs[l] : 0.0f), is[l], hit ? ps[l] : RF_INVALID);
    rf_tile_put(out, view_base + (size_t)(py * cam->width + px), px_hit);
  }
}

/* Traces tile `tile` of the ray list: rays[begin .. begin + count), count at
 * most RF_TILE_RAYS, and writes every pixel its rays answer. */
RF_INLINE void rf_trace_tile(const RF_GLOBAL rf_u32* rays, rf_u32 begin, rf_u32 count, const rf_camera* cam,
                             const RF_GLOBAL float* depth_scales, const rf_depth_table* depths,
                             const RF_GLOBAL rf_node* nodes, const RF_GLOBAL rf_wide_node* wide,
                             const RF_GLOBAL rf_tri* tris, const RF_GLOBAL rf_instance* instances,
                             const RF_GLOBAL rf_normal_xform* normal_xforms, rf_u32 tlas_root,
                             const rf_answers* out RF_TSTAT_PARAM RF_ALPHA_PARAM) {
  rf_tile_camera tc;
  rf_tile_hits hits[RF_MAX_GROUPS];
  rf_tile_ray ro[RF_TILE_SETUPS];
  for (int s = 0; s < RF_TILE_SETUPS; ++s) ro[s].valid = 0;
  /* The groups of each lane's ray by its entry's two mirror bits, the four
   * answers made once (the entries' decoding costs as much as a traversal
   * step otherwise); the traversal masks out the groups no ray of the tile
   * answers. Then rf_decode_entry_groups a lane group at a time, each lane's
   * operations the scalar code's: LLVM made the loop of one ray at a time,
   * with the index clamped to count and the table indexed by each entry, two
   * gathers a vector (a tenth of an interior's frame, the conference room's). */
  const rf_vu g0 = (rf_vu)(rf_entry_groups(0u, cam)), g1 = (rf_vu)(rf_entry_groups(RF_RAY_MIRROR_X, cam));
  const rf_vu g2 = (rf_vu)(rf_entry_groups(RF_RAY_MIRROR_Y, cam));
  const rf_vu g3 = (rf_vu)(rf_entry_groups(RF_RAY_MIRROR_X | RF_RAY_MIRROR_Y, cam));
  rf_u32 lane_groups[RF_TILE_RAYS];
  rf_vu all_groups = (rf_vu)(0u);
  for (int j = 0; j < RF_LANE_GROUPS; ++j) {
    const rf_u32 l0 = (rf_u32)j * RF_LANES;
    rf_vu e;
    if (l0 + RF_LANES <= count) {
      e = rf_lanes_load_u(0, rays + begin + l0);
    } else { /* lanes past count repeat the tile's last ray */
      rf_u32 last[RF_LANES];
      for (rf_u32 l = 0; l < RF_LANES; ++l) last[l] = rays[begin + min(l0 + l, count - 1u)];
      e = rf_lanes_load_u(0, last);
    }
    const rf_vi odd = (e & RF_RAY_MIRROR_X) != (rf_vu)(0u), high = (e & RF_RAY_MIRROR_Y) != (rf_vu)(0u);
    const rf_vu groups = select(select(g0, g1, odd), select(g2, g3, odd), high);
    rf_lanes_store_u(groups, 0, lane_groups + l0);
    all_groups |= groups;
    const rf_vi x = rf_lanes_as_vi(e & RF_RAY_COORD_MASK);
    const rf_vi y = rf_lanes_as_vi((e >> RF_RAY_COORD_BITS) & RF_RAY_COORD_MASK);
    tc.dx[j] = cam->scale_x * (rf_lanes_to_vf(2 * x + cam->kx0) + cam->frac_x);
    tc.dy[j] = cam->scale_y * (rf_lanes_to_vf(cam->ky0 - 2 * y) + cam->frac_y);
  }
  const rf_u32 tile_groups = rf_lanes_or(all_groups);
  rf_vf lo0 = (rf_vf)(RF_FAR), lo1 = lo0, hi0 = (rf_vf)(-RF_FAR), hi1 = hi0;
  for (int j = 0; j < RF_LANE_GROUPS; ++j) {
    tc.ix[j] = rf_lanes_reciprocal(tc.dx[j]);
    tc.iy[j] = rf_lanes_reciprocal(tc.dy[j]);
    lo0 = fmin(lo0, tc.ix[j]);
    lo1 = fmin(lo1, tc.iy[j]);
    hi0 = fmax(hi0, tc.ix[j]);
    hi1 = fmax(hi1, tc.iy[j]);
    /* Only the groups the tile answers: the others are never read, and
     * setting them all wrote 24 KiB a tile (4 groups' hits) where one view
     * unfolded needs 6. */
    const rf_vu lane_g = rf_lanes_load_u(j, lane_groups);
    RF_FOR_EACH_GROUP(g, tile_groups) {
      hits[g].t[j] = select((rf_vf)(-1.0f), (rf_vf)(RF_FAR), ((lane_g >> g) & 1u) != (rf_vu)(0u));
      hits[g].u[j] = (rf_vf)(0.0f);
      hits[g].v[j] = (rf_vf)(0.0f);
      hits[g].instance[j] = (rf_vu)(RF_INVALID);
      hits[g].prim[j] = (rf_vu)(RF_INVALID);
      hits[g].tri[j] = (rf_vu)(RF_INVALID);
    }
  }
  tc.lo[0] = rf_lanes_hmin(lo0);
  tc.lo[1] = rf_lanes_hmin(lo1);
  tc.lo[2] = -1.0f;
  tc.hi[0] = rf_lanes_hmax(hi0);
  tc.hi[1] = rf_lanes_hmax(hi1);
  tc.hi[2] = -1.0f;
  for (int g = 0; g < RF_MAX_GROUPS; ++g) hits[g].tmax = ((tile_groups >> g) & 1u) ? RF_FAR : -1.0f;

  if (tlas_root != RF_INVALID)
    rf_tile_trace_tlas(nodes, wide, tris, instances, tlas_root, &tc, 0, tile_groups, ro,
                       hits RF_TSTAT_ARG RF_ALPHA_ARG);

  rf_tile_pixel_rays pixel_rays;
  pixel_rays.view = RF_INVALID;
  RF_FOR_EACH_GROUP(g, tile_groups) {
    rf_tile_write_group(rays, begin, count, cam, lane_groups, &tc, &hits[g], g, depth_scales[g >> cam->group_shift],
                        depths, tris, normal_xforms, &pixel_rays, out);
  }
}

/* Answers a tile of ray queries that share one origin (bit for bit):
 * rays[begin .. begin + count), count at most RF_TILE_RAYS, each ray's
 * closest hit with tmin < t <= tmax written to out[order[begin + l]] (order
 * null: out[begin + l]) as rf_trace_query writes it (z = t). The same lanes as a camera tile, with
 * the shared origin, per-lane z directions and tmin of rf_tile_query; one
 * transform group, as a query frame has. Every lane gives the bits of the
 * scalar rf_trace_query of its ray (the reasons at the top of this file). */
RF_INLINE void rf_trace_query_tile(const rf_query_arrays* rays, rf_u32 begin, rf_u32 count,
                                   const RF_GLOBAL rf_node* nodes, const RF_GLOBAL rf_wide_node* wide,
                                   const RF_GLOBAL rf_tri* tris, const RF_GLOBAL rf_instance* instances,
                                   const RF_GLOBAL rf_normal_xform* normal_xforms, rf_u32 tlas_root, rf_u32 write_flags,
                                   const RF_GLOBAL rf_u32* order,
                                   RF_GLOBAL rf_pixel_hit* out RF_TSTAT_PARAM RF_ALPHA_PARAM) {
  rf_tile_camera tc;
  rf_tile_query q;
  rf_tile_hits hits[1];
  rf_tile_ray ro[1];
  ro[0].valid = 0;
  float* dx = (float*)tc.dx;
  float* dy = (float*)tc.dy;
  float* dz = (float*)q.dz;
  float* tmin = (float*)q.tmin;
  float* tmax = (float*)hits[0].t;
  const rf_i32 e = rays->exponent;
  const size_t first = order ? order[begin] : begin;
  for (int a = 0; a < 3; ++a) q.o[a] = rf_pow2_scale(rays->origins[3 * first + a], e);
  for (int l = 0; l < RF_TILE_RAYS; ++l) {
    const rf_u32 k = begin + ((rf_u32)l < count ? (rf_u32)l : count - 1u);
    const RF_GLOBAL float* d = rays->directions + 3 * (size_t)(order ? order[k] : k);
    dx[l] = rf_pow2_scale(d[0], e);
    dy[l] = rf_pow2_scale(d[1], e);
    dz[l] = rf_pow2_scale(d[2], e);
    tmin[l] = rays->tmin;
    tmax[l] = rays->tmax; /* the hit to beat starts at tmax, as rf_trace_query's */
  }
  rf_vf lo0 = (rf_vf)(RF_FAR), lo1 = lo0, lo2 = lo0, hi0 = (rf_vf)(-RF_FAR), hi1 = hi0, hi2 = hi0;
  for (int j = 0; j < RF_LANE_GROUPS; ++j) {
    tc.ix[j] = rf_lanes_reciprocal(tc.dx[j]);
    tc.iy[j] = rf_lanes_reciprocal(tc.dy[j]);
    q.iz[j] = rf_lanes_reciprocal(q.dz[j]);
    lo0 = fmin(lo0, tc.ix[j]);
    lo1 = fmin(lo1, tc.iy[j]);
    lo2 = fmin(lo2, q.iz[j]);
    hi0 = fmax(hi0, tc.ix[j]);
    hi1 = fmax(hi1, tc.iy[j]);
    hi2 = fmax(hi2, q.iz[j]);
    hits[0].u[j] = (rf_vf)(0.0f);
    hits[0].v[j] = (rf_vf)(0.0f);
    hits[0].instance[j] = (rf_vu)(RF_INVALID);
    hits[0].prim[j] = (rf_vu)(RF_INVALID);
    hits[0].tri[j] = (rf_vu)(RF_INVALID);
  }
  tc.lo[0] = rf_lanes_hmin(lo0);
  tc.lo[1] = rf_lanes_hmin(lo1);
  tc.lo[2] = rf_lanes_hmin(lo2);
  tc.hi[0] = rf_lanes_hmax(hi0);
  tc.hi[1] = rf_lanes_hmax(hi1);
  tc.hi[2] = rf_lanes_hmax(hi2);
  rf_tile_update_tmax(&hits[0]);
  if (tlas_root != RF_INVALID)
    rf_tile_trace_tlas(nodes, wide, tris, instances, tlas_root, &tc, &q, 1u, ro, hits RF_TSTAT_ARG RF_ALPHA_ARG);

  rf_vf nx[RF_LANE_GROUPS], ny[RF_LANE_GROUPS], nz[RF_LANE_GROUPS];
  rf_tile_normal_cache normal_cache;
  normal_cache.tri = RF_INVALID;
  for (int j = 0; j < RF_LANE_GROUPS; ++j) {
    const rf_vi hit = hits[0].instance[j] != (rf_vu)(RF_INVALID);
    if (!rf_lanes_any(hit) || (write_flags & RF_WRITE_NO_NORMALS)) {
      nx[j] = ny[j] = nz[j] = (rf_vf)(0.0f);
      continue;
    }
    rf_tile_lane_normals(&hits[0], j, hit, tris, normal_xforms, &normal_cache, &nx[j], &ny[j], &nz[j]);
  }
  const float* ts = (const float*)hits[0].t;
  const float* xs = (const float*)nx;
  const float* ys = (const float*)ny;
  const float* ws = (const float*)nz;
  const float* us = (const float*)hits[0].u;
  const float* vs = (const float*)hits[0].v;
  const rf_u32* is = (const rf_u32*)hits[0].instance;
  const rf_u32* ps = (const rf_u32*)hits[0].prim;
  for (rf_u32 l = 0; l < count; ++l) {
    const int hit = is[l] != RF_INVALID;
    /* z: t * 1 * 1, as rf_write_pixel's query form; as integers, as the
     * camera tile's stores. */
    const uint8 px_hit = (uint8)(as_uint(hit ? ts[l] : RF_INF), as_uint(xs[l]), as_uint(ys[l]), as_uint(ws[l]),
                                 as_uint(hit ? us[l] : 0.0f), as_uint(hit ? vs[l] : 0.0f), is[l],
                                 hit ? ps[l] : RF_INVALID);
    vstore8(px_hit, 0, (RF_GLOBAL rf_u32*)&out[order ? order[begin + l] : begin + l]);
  }
}

#endif /* RF_TILE_H */
