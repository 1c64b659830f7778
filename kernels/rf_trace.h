/* rf_trace.h - two-level closest-hit traversal with one hit record per
 * transform group, and the per-ray entry point that writes every pixel the ray
 * answers. Shared by the kernels and the CPU reference (see rf_common.h). */
#ifndef RF_TRACE_H
#define RF_TRACE_H

#ifndef __OPENCL_C_VERSION__
#include "rf_alpha.h"
#include "rf_common.h"
#include "rf_depth.h"
#include "rf_geometry.h"
#include "rf_types.h"
#endif

/* Object-space rays kept per camera ray (a power of two). */
#define RF_RAY_CACHE 8

/* The closest hit found so far for one transform group. */
typedef struct {
  float t, u, v;
  rf_u32 instance; /* scene instance id, RF_INVALID while nothing is hit */
  rf_u32 prim;     /* triangle index within the mesh */
  rf_u32 tri;      /* index into the triangle array, for the normal */
} rf_hit;

RF_INLINE void rf_hit_reset(rf_hit* h) {
  h->t = RF_FAR;
  h->u = 0.0f;
  h->v = 0.0f;
  h->instance = RF_INVALID;
  h->prim = RF_INVALID;
  h->tri = RF_INVALID;
}

/* The tie rule: equal t, the lower instance id wins, then the lower primitive.
 * A total order, so the closest hit does not depend on traversal order. */
RF_INLINE int rf_hit_is_closer(float t, rf_u32 instance, rf_u32 prim, const rf_hit* best) {
  if (t != best->t) return t < best->t;
  if (instance != best->instance) return instance < best->instance;
  return prim < best->prim;
}

/* The distance a hit competes with and is reported at: the triangle test's
 * t, raised to the entry distance of the leaf it was found in. Traversal
 * skips a node whose entry lies beyond the current hit, so the closest hit
 * is found in every traversal order (folded or not, scalar or in lanes) only
 * if no hit lies nearer than the boxes around it. The box entries are
 * accurate, but the triangle test's t of a ray grazing a large triangle is not
 * (its error grows with 1 / sin of the angle), nor is t at the edge of the
 * float range; there the raise keeps the order irrelevant. Elsewhere t is at
 * or beyond the widened entry and unchanged [Stress.*, Scale.*]. */
RF_INLINE float rf_hit_distance(float t, float leaf_entry) { return t < leaf_entry ? leaf_entry : t; }

/* The triangles tris[first .. first + count) of a leaf whose box the ray
 * enters at node_t, beyond tmin, into best; 1 when any_hit and a hit was
 * taken (the traversal stops). */
RF_INLINE int rf_trace_leaf(const RF_GLOBAL rf_tri* tris, rf_u32 first, rf_u32 count, const rf_ray* r,
                            rf_u32 instance_id, float tmin, float node_t, int any_hit, rf_hit* best RF_ALPHA_PARAM) {
  for (rf_u32 ti = first; ti < first + count; ++ti) {
    RF_STAT(triangles);
    float t, u, v;
    if (!rf_intersect_triangle(&tris[ti], r, &t, &u, &v) || !(t > tmin)) continue;
    t = rf_hit_distance(t, node_t);
    const rf_u32 instance = instance_id + tris[ti].inst;
    if (rf_hit_is_closer(t, instance, tris[ti].prim, best) RF_ALPHA_KEEPS(ti, u, v)) {
      best->t = t;
      best->u = u;
      best->v = v;
      best->instance = instance;
      best->prim = tris[ti].prim;
      best->tri = ti;
      if (any_hit) return 1;
    }
  }
  return 0;
}

#ifdef __OPENCL_C_VERSION__
/* The elements of a vector comparison's result (each -1 or 0) that are
 * true, as bits (element k bit k). (The path's test in rf_unit_tests.cl,
 * ut_lane_bits_path, names the same condition.) On x86 through clang (PoCL) the sign
 * bits in one instruction (movmskps): the OR tree below, which neither
 * PoCL nor clang's own reduction turns into it, sat on the path from each
 * node's box test to the branch on its children (1M scattered rays 1.04x to
 * 1.05x faster). */
RF_INLINE rf_u32 rf_lane_bits8(int8 v) {
#if defined(RF_CLANG_BUILTINS) && defined(__AVX__)
  return (rf_u32)__builtin_ia32_movmskps256(as_float8(v));
#else
  const int8 bits = v & (int8)(1, 2, 4, 8, 16, 32, 64, 128);
  const int4 bits4 = bits.lo | bits.hi;
  const int2 bits2 = bits4.lo | bits4.hi;
  return (rf_u32)(bits2.x | bits2.y);
#endif
}

/* Leaves of fewer triangles are tested one by one: on the conference room
 * and Lost Empire (about 2 a leaf) the vector test of every leaf traced
 * 0.96x as fast. */
#define RF_LEAF_WIDE_MIN 3u
/* The triangles of tris[first .. first + n) (n <= 8) whose edge functions
 * do not reject the ray (rf_intersect_triangle's sign test), as bits: the
 * test's operations for eight triangles at once, element k triangle k,
 * each element the scalar test's bits. Elements past n repeat the last
 * triangle and are masked off. */
RF_INLINE rf_u32 rf_leaf_candidates8(const RF_GLOBAL rf_tri* tris, rf_u32 first, rf_u32 n, const rf_ray* r) {
#define RF_TRI8(v, axis)                                                                                          \
  (float8)(tris[first].v[axis], tris[first + min(1u, n - 1u)].v[axis], tris[first + min(2u, n - 1u)].v[axis],     \
           tris[first + min(3u, n - 1u)].v[axis], tris[first + min(4u, n - 1u)].v[axis],                          \
           tris[first + min(5u, n - 1u)].v[axis], tris[first + min(6u, n - 1u)].v[axis],                          \
           tris[first + min(7u, n - 1u)].v[axis])
  RF_WATERTIGHT_EDGES(float8, RF_TRI8, r);
#undef RF_TRI8
  const int8 negative = (eu < 0.0f) | (ev < 0.0f) | (ew < 0.0f);
  const int8 positive = (eu > 0.0f) | (ev > 0.0f) | (ew > 0.0f);
  return rf_lane_bits8(~(negative & positive)) & ((1u << n) - 1u);
}

/* rf_trace_leaf with its triangles' sign tests eight at a time
 * (rf_leaf_candidates8), the whole test then only for those left (most
 * rays meet none of a leaf's triangles): the same triangles tested, in the
 * same order, so the same hits. 1M scattered rays 1.09x to 1.10x faster on
 * the armadillo and the dragon (4.7 triangles a leaf), 1.06x on the car,
 * 0.99x to 1.03x elsewhere. */
RF_INLINE int rf_trace_leaf_wide(const RF_GLOBAL rf_tri* tris, rf_u32 first, rf_u32 count, const rf_ray* r,
                                 rf_u32 instance_id, float tmin, float node_t, int any_hit,
                                 rf_hit* best RF_ALPHA_PARAM) {
  if (count < RF_LEAF_WIDE_MIN)
    return rf_trace_leaf(tris, first, count, r, instance_id, tmin, node_t, any_hit, best RF_ALPHA_ARG);
  for (rf_u32 chunk = first; chunk < first + count; chunk += 8u) {
    const rf_u32 n = min(8u, first + count - chunk);
    for (rf_u32 mask = rf_leaf_candidates8(tris, chunk, n, r); mask != 0u; mask &= mask - 1u)
      if (rf_trace_leaf(tris, chunk + RF_CTZ(mask), 1u, r, instance_id, tmin, node_t, any_hit, best RF_ALPHA_ARG))
        return 1;
  }
  return 0;
}
#endif

/* Closest hit of one object-space ray in one bottom-level tree, beyond
 * tmin (0 for camera rays); any_hit: stop at the first hit (occlusion). */
RF_INLINE void rf_trace_blas(const RF_GLOBAL rf_node* nodes, const RF_GLOBAL rf_tri* tris, rf_u32 root, const rf_ray* r,
                             rf_u32 instance_id, float tmin, int any_hit, rf_hit* best RF_ALPHA_PARAM) {
  rf_u32 stack_node[RF_STACK_SIZE];
  float stack_t[RF_STACK_SIZE];
  int sp = 0;
  float node_t = rf_intersect_box(&nodes[root], r, best->t);
  if (node_t == RF_FAR) return;
  rf_u32 ni = root;
  for (;;) {
    const RF_GLOBAL rf_node* n = &nodes[ni];
    const rf_u32 count = n->meta & RF_NODE_COUNT_MASK;
    RF_STAT(blas_nodes);
    if (count != 0) {
      if (rf_trace_leaf(tris, n->first, count, r, instance_id, tmin, node_t, any_hit, best RF_ALPHA_ARG)) return;
    } else {
      const rf_u32 c = n->first;
      const float t0 = rf_intersect_box(&nodes[c], r, best->t);
      const float t1 = rf_intersect_box(&nodes[c + 1], r, best->t);
      if (t0 != RF_FAR || t1 != RF_FAR) {
        const int left_first = t0 <= t1;
        const rf_u32 near_node = left_first ? c : c + 1;
        if (t0 != RF_FAR && t1 != RF_FAR) {
          stack_node[sp] = left_first ? c + 1 : c;
          stack_t[sp] = left_first ? t1 : t0;
          ++sp;
        }
        ni = near_node;
        node_t = left_first ? t0 : t1;
        continue;
      }
    }
    /* Pop, skipping entries whose entry distance the hit has since passed. */
    for (;;) {
      if (sp == 0) return;
      --sp;
      if (stack_t[sp] <= best->t) {
        ni = stack_node[sp];
        node_t = stack_t[sp];
        break;
      }
    }
  }
}

#ifdef __OPENCL_C_VERSION__
/* rf_intersect_box for the eight child boxes of an 8-wide node at once,
 * element k child k. The vector's elements are boxes, not parts of one
 * ray's arithmetic: each is the scalar test's operations, so its bits. One
 * of them is left out: of a slab's two ends rf_minf takes the one at the
 * box's low side when the reciprocal is positive, and the high side's when
 * it is negative (it is never 0 nor infinite, rf_safe_reciprocal), since
 * lo <= hi and rounding is monotone; on a tie both ends are the same float
 * (the same difference times the same reciprocal), so choosing the end by
 * the reciprocal's sign gives rf_minf's and rf_maxf's bits without them. */
RF_INLINE float8 rf_intersect_box8(const RF_GLOBAL rf_wide8_node* n, const rf_ray* r, float tmax) {
#define RF_MIN8(a, b) select((b), (a), (a) < (b))
#define RF_MAX8(a, b) select((b), (a), (a) > (b))
  const float8 lx = vload8(0, n->lo_x), ly = vload8(0, n->lo_y), lz = vload8(0, n->lo_z);
  const float8 hx = vload8(0, n->hi_x), hy = vload8(0, n->hi_y), hz = vload8(0, n->hi_z);
  const int px = r->invd[0] >= 0.0f, py = r->invd[1] >= 0.0f, pz = r->invd[2] >= 0.0f;
  const float8 nx = ((px ? lx : hx) - r->o[0]) * r->invd[0], fx = ((px ? hx : lx) - r->o[0]) * r->invd[0];
  const float8 ny = ((py ? ly : hy) - r->o[1]) * r->invd[1], fy = ((py ? hy : ly) - r->o[1]) * r->invd[1];
  const float8 nz = ((pz ? lz : hz) - r->o[2]) * r->invd[2], fz = ((pz ? hz : lz) - r->o[2]) * r->invd[2];
  const float8 tnear = RF_MAX8(RF_MAX8(nx, ny), RF_MAX8(nz, (float8)(0.0f))) * RF_BOX_NEAR_SCALE;
  const float8 tfar = RF_MIN8(RF_MIN8(fx, fy), fz) * RF_BOX_FAR_SCALE;
  return select((float8)(RF_FAR), tnear, tnear <= RF_MIN8(tfar, (float8)(tmax)));
#undef RF_MIN8
#undef RF_MAX8
}

/* The single-ray walk's stack: children (rf_wide8_node's child and count)
 * to visit and the distance the ray enters them at. Each 8-wide node pushes
 * at most eight and pops one, and descends at least one binary level. Its
 * size is the walk's own local (passed to the steps by address): in the
 * struct it stayed in memory, stored and loaded again at every push and
 * pop (1M scattered rays 1.005x to 1.03x faster on all seven scenes). */
#define RF_WIDE_RAY_STACK (7 * RF_STACK_SIZE + 1)
typedef struct {
  rf_u32 child[RF_WIDE_RAY_STACK], count[RF_WIDE_RAY_STACK];
  float t[RF_WIDE_RAY_STACK];
} rf_wide_stack;

/* One step into 8-wide node n: the children the ray enters at or before
 * tmax, farthest first onto the stack, so that the nearest is taken next;
 * or, when it enters one alone (the common case), that one into *child,
 * *count and *t without the stack (returns 1). Always inlined: PoCL kept
 * it a call, its answers passed through memory (1M scattered rays 1.03x
 * faster inlined in the conference room and the car, the dragon the same).
 * (A separate path for two children, the nearer taken and the other
 * pushed without the loop, measured 0.97x to 1.03x: left out.) */
RF_INLINE_ALWAYS int rf_wide_step(const RF_GLOBAL rf_wide8_node* n, const rf_ray* r, float tmax, rf_wide_stack* s,
                                  int* size, rf_u32* child, rf_u32* count, float* t) {
  const float8 tv = rf_intersect_box8(n, r, tmax);
  /* The entered children as bits: a branch per child on whether the ray
   * enters it held a quarter of the 4-wide walk's samples (perf), most of
   * them mispredictions. */
  rf_u32 mask = rf_lane_bits8((tv != (float8)(RF_FAR)) & (vload8(0, n->count) != (uint8)(RF_INVALID)));
  float t8[8];
  vstore8(tv, 0, t8);
  if (mask != 0u && (mask & (mask - 1u)) == 0u) {
    const rf_u32 k = RF_CTZ(mask);
    *child = n->child[k];
    *count = n->count[k];
    *t = t8[k];
    return 1;
  }
  const int base = *size;
  for (; mask != 0u; mask &= mask - 1u) {
    const rf_u32 k = RF_CTZ(mask);
    const float tk = t8[k];
    int i = (*size)++;
    for (; i > base && s->t[i - 1] < tk; --i) {
      s->t[i] = s->t[i - 1];
      s->child[i] = s->child[i - 1];
      s->count[i] = s->count[i - 1];
    }
    s->t[i] = tk;
    s->child[i] = n->child[k];
    s->count[i] = n->count[k];
  }
  return 0;
}

/* The next entry the ray may still improve on (entered at or before bound)
 * into *child, *count and *t; 0 when none is left. */
RF_INLINE int rf_wide_pop(const rf_wide_stack* s, int* size, float bound, rf_u32* child, rf_u32* count, float* t) {
  while (*size > 0) {
    const int i = --*size;
    if (s->t[i] > bound) continue;
    *child = s->child[i];
    *count = s->count[i];
    *t = s->t[i];
    return 1;
  }
  return 0;
}

/* The children a step pushed below the nearest (stack entries [from, to)),
 * their nodes' or triangles' cache lines asked for while the nearest is
 * walked: the first load of a node's boxes is the walk's hottest
 * instruction in perf, a cache miss on the dense meshes, whose trees and
 * triangles are far larger than the cache. 1M scattered rays 1.06x faster
 * on the armadillo, 1.11x on the dragon; Sponza and Lost Empire 1.02x, the
 * conference room and the car 0.98x to 1.01x. The nearest child is read at
 * once, too soon for a hint. */
RF_INLINE void rf_wide_prefetch_pushed(const rf_wide_stack* s, int from, int to, const RF_GLOBAL rf_wide8_node* wide,
                                       const RF_GLOBAL rf_tri* tris) {
  for (int i = from; i < to; ++i) {
    const rf_u32 c = s->child[i], count = s->count[i];
    if (count == 0u)
      rf_prefetch_bytes((const RF_GLOBAL char*)&wide[c], (const RF_GLOBAL char*)&wide[c + 1]);
    else
      rf_prefetch_bytes((const RF_GLOBAL char*)&tris[c], (const RF_GLOBAL char*)&tris[c + count]);
  }
}

/* rf_trace_blas through the 8-wide tree of the same leaves (binary root
 * `root`, its children in 8-wide node `wide_root`; rf_types.h,
 * rf_wide8_node): the same hits, bit for bit. A leaf is entered where its
 * own box test passes, which the binary traversal's ancestors pass too
 * (their boxes hold it, and rounding is monotone), and each hit's t is
 * raised to that leaf's entry as there; the tie rule makes the order of
 * the leaves irrelevant. A scattered ray's walk is bound by its steps,
 * and an 8-wide step decides eight boxes in one vector test (1M scattered
 * rays 1.06x to 1.12x faster than through the 4-wide trees). */
RF_INLINE void rf_trace_blas_wide(const RF_GLOBAL rf_node* nodes, const RF_GLOBAL rf_wide8_node* wide,
                                  const RF_GLOBAL rf_tri* tris, rf_u32 root, rf_u32 wide_root, const rf_ray* r,
                                  rf_u32 instance_id, float tmin, int any_hit, rf_hit* best RF_ALPHA_PARAM) {
  const RF_GLOBAL rf_node* rn = &nodes[root];
  float t = rf_intersect_box(rn, r, best->t);
  if (t == RF_FAR) return;
  rf_u32 child = wide_root, count = 0;
  if (wide_root == RF_INVALID) { /* the root is a leaf */
    child = rn->first;
    count = rn->meta & RF_NODE_COUNT_MASK;
  }
  rf_wide_stack s;
  int size = 0;
  for (;;) {
    if (count == 0u) {
      RF_STAT(blas_nodes);
      const int before = size;
      if (rf_wide_step(&wide[child], r, best->t, &s, &size, &child, &count, &t)) continue;
      rf_wide_prefetch_pushed(&s, before, size - 1, wide, tris);
    } else if (rf_trace_leaf_wide(tris, child, count, r, instance_id, tmin, t, any_hit, best RF_ALPHA_ARG)) {
      return;
    }
    if (!rf_wide_pop(&s, &size, best->t, &child, &count, &t)) return;
  }
}
#endif

/* Pruning bound of a top-level node: the farthest current hit among the
 * groups that both lie below the node (its meta) and are traced by this ray.
 * A node is skipped only when it cannot improve any of them; -1 when none
 * applies. */
RF_INLINE float rf_group_bound(rf_u32 meta, rf_u32 ray_groups, const rf_hit* hits) {
  float bound = -1.0f;
  RF_FOR_EACH_GROUP(g, meta & ray_groups) { bound = rf_maxf(bound, hits[g].t); }
  return bound;
}

/* How rf_trace_tlas's ray starts in trace space. */
#define RF_ORIGIN_EYE 0   /* at the eye, 0 (perspective cameras) */
#define RF_ORIGIN_PLANE 1 /* at (ox, oy, 0) on the image plane (orthographic) */
#define RF_ORIGIN_ANY 2   /* at (ox, oy, oz) (ray queries) */

/* With re-braiding, one instance enters the top level as several subtrees
 * that a ray meets at different times; a small direct-mapped cache keeps
 * the object-space rays of recent (instance, group) pairs. Reuse gives the
 * same bits as setting the ray up again. */
typedef struct {
  rf_ray ray[RF_RAY_CACHE];
  rf_u32 key[RF_RAY_CACHE];
} rf_ray_cache;

RF_INLINE void rf_ray_cache_reset(rf_ray_cache* c) {
  for (int k = 0; k < RF_RAY_CACHE; ++k) c->key[k] = RF_INVALID;
}

/* The instances [first, first + count) of a top-level leaf: each that the
 * ray answers (its group in ray_groups) set up in tree space through the
 * cache and traced into hits[its group] (through the 8-wide trees when
 * wide, device only: instance j's root wide_roots[j]). 1 when any_hit and a
 * hit was found. */
RF_INLINE int rf_trace_instances(const RF_GLOBAL rf_node* nodes, const RF_GLOBAL rf_wide8_node* wide,
                                 const RF_GLOBAL rf_u32* wide_roots, const RF_GLOBAL rf_tri* tris,
                                 const RF_GLOBAL rf_instance* instances, rf_u32 first, rf_u32 count, rf_i32 origin,
                                 float ox, float oy, float oz, float dx, float dy, float dz, float tmin, int any_hit,
                                 rf_u32 ray_groups, rf_ray_cache* cache, rf_hit* hits RF_ALPHA_PARAM) {
  for (rf_u32 k = 0; k < count; ++k) {
    const RF_GLOBAL rf_instance* inst = &instances[first + k];
    const rf_u32 g = inst->group;
    if (((ray_groups >> g) & 1u) == 0u) continue;
    RF_STAT(instances);
    /* Unique while instance ids stay below 2^32 / RF_GROUP_LIMIT
     * (prepare_scene checks). */
    const rf_u32 key = inst->instance_id * (rf_u32)RF_MAX_GROUPS + g;
    const rf_u32 slot = key & (rf_u32)(RF_RAY_CACHE - 1);
    rf_ray* ro = &cache->ray[slot];
    if (cache->key[slot] != key) {
      RF_STAT(setups);
      if (origin == RF_ORIGIN_ANY)
        rf_ray_to_object_at(ro, inst->tree_from_trace, ox, oy, oz, dx, dy, dz);
      else if (origin == RF_ORIGIN_PLANE)
        rf_ray_to_object_from(ro, inst->tree_from_trace, ox, oy, dx, dy, dz);
      else
        rf_ray_to_object(ro, inst->tree_from_trace, dx, dy, dz);
      cache->key[slot] = key;
    }
#ifdef __OPENCL_C_VERSION__
    if (wide)
      rf_trace_blas_wide(nodes, wide, tris, inst->blas_root, wide_roots[first + k], ro, inst->instance_id, tmin,
                         any_hit, &hits[g] RF_ALPHA_ARG);
    else
#else
    (void)wide;
    (void)wide_roots;
#endif
      rf_trace_blas(nodes, tris, inst->blas_root, ro, inst->instance_id, tmin, any_hit, &hits[g] RF_ALPHA_ARG);
    if (any_hit && hits[g].instance != RF_INVALID) return 1;
  }
  return 0;
}

/* Closest hit per group of one trace-space ray through the top-level tree,
 * from the origin `origin` names along (dx, dy, dz), beyond tmin; any_hit:
 * stop at the first hit. ray_groups: bit g set when the ray answers group g.
 * Binary trees at both levels (the CPU reference's walk). */
RF_INLINE void rf_trace_tlas(const RF_GLOBAL rf_node* nodes, const RF_GLOBAL rf_tri* tris,
                             const RF_GLOBAL rf_instance* instances, rf_u32 tlas_root, rf_i32 origin, float ox,
                             float oy, float oz, float dx, float dy, float dz, float tmin, int any_hit,
                             rf_u32 ray_groups, rf_hit* hits RF_ALPHA_PARAM) {
  rf_u32 stack_node[RF_STACK_SIZE];
  float stack_t[RF_STACK_SIZE];
  int sp = 0;
  rf_ray r;
  rf_ray_init(&r, ox, oy, oz, dx, dy, dz);
  rf_ray_cache cache;
  rf_ray_cache_reset(&cache);
  if (rf_intersect_box(&nodes[tlas_root], &r, rf_group_bound(nodes[tlas_root].meta, ray_groups, hits)) == RF_FAR)
    return;
  rf_u32 ni = tlas_root;
  for (;;) {
    const RF_GLOBAL rf_node* n = &nodes[ni];
    const rf_u32 count = n->first >> RF_TLAS_COUNT_SHIFT;
    const rf_u32 first = n->first & RF_TLAS_INDEX_MASK;
    RF_STAT(tlas_nodes);
    if (count != 0) {
      if (rf_trace_instances(nodes, 0, 0, tris, instances, first, count, origin, ox, oy, oz, dx, dy, dz, tmin, any_hit,
                             ray_groups, &cache, hits RF_ALPHA_ARG))
        return;
    } else {
      const rf_u32 c = first;
      const float t0 = rf_intersect_box(&nodes[c], &r, rf_group_bound(nodes[c].meta, ray_groups, hits));
      const float t1 = rf_intersect_box(&nodes[c + 1], &r, rf_group_bound(nodes[c + 1].meta, ray_groups, hits));
      if (t0 != RF_FAR || t1 != RF_FAR) {
        const int left_first = t0 <= t1;
        if (t0 != RF_FAR && t1 != RF_FAR) {
          stack_node[sp] = left_first ? c + 1 : c;
          stack_t[sp] = left_first ? t1 : t0;
          ++sp;
        }
        ni = left_first ? c : c + 1;
        continue;
      }
    }
    for (;;) {
      if (sp == 0) return;
      --sp;
      if (stack_t[sp] <= rf_group_bound(nodes[stack_node[sp]].meta, ray_groups, hits)) {
        ni = stack_node[sp];
        break;
      }
    }
  }
}

#ifdef __OPENCL_C_VERSION__
/* rf_trace_tlas for a ray query (one group, every instance in it: a query
 * frame has one view and no mirrors), the top level through its 8-wide
 * nodes too: `tlas_wide` holds the binary root's children in 8-wide node
 * tlas_wide_root (RF_INVALID: the root is a leaf), a leaf child's `child`
 * its first instance and `count` their number (host/bvh/wide_bvh.h,
 * build_wide8_tlas); instance j's whole tree from wide_roots[j]
 * (host/rays/ray_queries.h, build_query_trees). The same hits as the
 * binary walk, for the reasons of rf_trace_blas_wide. */
RF_INLINE void rf_trace_query_tlas_wide(const RF_GLOBAL rf_node* nodes, const RF_GLOBAL rf_wide8_node* wide,
                                        const RF_GLOBAL rf_wide8_node* tlas_wide, rf_u32 tlas_wide_root,
                                        const RF_GLOBAL rf_u32* wide_roots, const RF_GLOBAL rf_tri* tris,
                                        const RF_GLOBAL rf_instance* instances, rf_u32 tlas_root, float ox, float oy,
                                        float oz, float dx, float dy, float dz, float tmin, int any_hit,
                                        rf_hit* hit RF_ALPHA_PARAM) {
  const RF_GLOBAL rf_node* root = &nodes[tlas_root];
  /* A top level that is one leaf (a scene of a few trees, each entered
   * whole): its instances straight away, without the trace-space ray and
   * the root's box. That box holds every instance's box (frame.cpp pads it
   * for the rounding of the ray's transform), so a ray it turns away meets
   * no triangle in them either, as the 8-wide walk already takes for the
   * binary nodes it skips. 1M scattered rays 1.04x to 1.08x faster. */
  if (tlas_wide_root == RF_INVALID) {
    const rf_u32 first = root->first & RF_TLAS_INDEX_MASK, count = root->first >> RF_TLAS_COUNT_SHIFT;
    for (rf_u32 k = first; k < first + count; ++k) {
      const RF_GLOBAL rf_instance* inst = &instances[k];
      rf_ray ro;
      rf_ray_to_object_at(&ro, inst->tree_from_trace, ox, oy, oz, dx, dy, dz);
      rf_trace_blas_wide(nodes, wide, tris, inst->blas_root, wide_roots[k], &ro, inst->instance_id, tmin, any_hit,
                         hit RF_ALPHA_ARG);
      if (any_hit && hit->instance != RF_INVALID) return;
    }
    return;
  }
  rf_ray r;
  rf_ray_init(&r, ox, oy, oz, dx, dy, dz);
  float t = rf_intersect_box(root, &r, hit->t);
  if (t == RF_FAR) return;
  rf_ray_cache cache;
  rf_ray_cache_reset(&cache);
  rf_u32 child = tlas_wide_root, count = 0;
  rf_wide_stack s;
  int size = 0;
  for (;;) {
    if (count == 0u) {
      RF_STAT(tlas_nodes);
      if (rf_wide_step(&tlas_wide[child], &r, hit->t, &s, &size, &child, &count, &t)) continue;
    } else if (rf_trace_instances(nodes, wide, wide_roots, tris, instances, child, count, RF_ORIGIN_ANY, ox, oy, oz, dx,
                                  dy, dz, tmin, any_hit, 1u, &cache, hit RF_ALPHA_ARG)) {
      return;
    }
    if (!rf_wide_pop(&s, &size, hit->t, &child, &count, &t)) return;
  }
}
#endif

/* Writes one pixel's hit info. len_d is the length of the trace-space ray
 * direction, which turns t into distance along the normalised ray, and
 * depth_scale the power of two that takes trace units to world units. */
RF_INLINE void rf_write_pixel(rf_pixel_hit* px, const rf_hit* h, float len_d, float depth_scale,
                              const RF_GLOBAL rf_tri* tris, const RF_GLOBAL rf_normal_xform* normal_xforms,
                              rf_u32 write_flags) {
  if (h->instance == RF_INVALID) {
    px->z = RF_INF;
    px->nx = 0.0f;
    px->ny = 0.0f;
    px->nz = 0.0f;
    px->u = 0.0f;
    px->v = 0.0f;
    px->instance = RF_INVALID;
    px->primitive = RF_INVALID;
    return;
  }
  float n[3] = {0.0f, 0.0f, 0.0f};
  if (!(write_flags & RF_WRITE_NO_NORMALS)) rf_geometric_normal(&tris[h->tri], &normal_xforms[h->instance], n);
  px->z = (write_flags & RF_WRITE_PLANAR_DEPTH) ? h->t * depth_scale : (h->t * len_d) * depth_scale;
  px->nx = n[0];
  px->ny = n[1];
  px->nz = n[2];
  px->u = h->u;
  px->v = h->v;
  px->instance = h->instance;
  px->primitive = h->prim;
}

/* One entry of the compacted ray list, decoded: its pixel, the transform
 * groups it answers (bit g: group g, in every view of the pass) and its
 * camera-space direction (the eye is the origin, dz = -1), or for an
 * orthographic camera (dx, dy) its origin on the image plane. Every kernel
 * generates rays through this. */
typedef struct {
  rf_i32 x, y;
  rf_u32 groups;
  float dx, dy;
} rf_camera_ray;

/* The groups a ray answers, from its entry's mirror bits (bit m of
 * `answered`: mirror m's pixel is answered, its bits being among the
 * entry's); slot s takes the bit of its mirror, and every view of the pass
 * has the same slots. */
RF_INLINE rf_u32 rf_entry_groups(rf_u32 entry, const rf_camera* cam) {
  const rf_u32 mx = (entry & RF_RAY_MIRROR_X) != 0u ? 1u : 0u;
  const rf_u32 my = (entry & RF_RAY_MIRROR_Y) != 0u ? 1u : 0u;
  const rf_u32 answered = 1u | (mx << 1) | (my << 2) | ((mx & my) << 3);
  const rf_u32 sm = cam->slot_mirrors;
  rf_u32 slots = (answered >> (sm & 3u)) & 1u;
  slots |= ((answered >> ((sm >> 2) & 3u)) & 1u) << 1;
  slots |= ((answered >> ((sm >> 4) & 3u)) & 1u) << 2;
  slots |= ((answered >> ((sm >> 6) & 3u)) & 1u) << 3;
  slots &= (1u << (1u << cam->group_shift)) - 1u;
  return slots * cam->view_rep;
}

/* The pixel of a ray-list entry and its camera-space ray; groups as
 * given. */
RF_INLINE rf_camera_ray rf_decode_entry_groups(rf_u32 entry, const rf_camera* cam, rf_u32 groups) {
  rf_camera_ray r;
  r.x = (rf_i32)(entry & RF_RAY_COORD_MASK);
  r.y = (rf_i32)((entry >> RF_RAY_COORD_BITS) & RF_RAY_COORD_MASK);
  r.groups = groups;
  r.dx = cam->scale_x * ((float)(2 * r.x + cam->kx0) + cam->frac_x);
  r.dy = cam->scale_y * ((float)(cam->ky0 - 2 * r.y) + cam->frac_y);
  return r;
}

RF_INLINE rf_camera_ray rf_decode_entry(rf_u32 entry, const rf_camera* cam) {
  return rf_decode_entry_groups(entry, cam, rf_entry_groups(entry, cam));
}

/* Group g's mirror (bit 0: camera x negated, bit 1: y) and the index of
 * its view's first pixel in the pass's output. */
RF_INLINE rf_u32 rf_group_mirror(rf_u32 g, const rf_camera* cam) {
  return (cam->slot_mirrors >> (2u * (g & ((1u << cam->group_shift) - 1u)))) & 3u;
}
RF_INLINE size_t rf_group_view_base(rf_u32 g, const rf_camera* cam) {
  return (size_t)(g >> cam->group_shift) * (size_t)cam->width * (size_t)cam->height;
}

/* Where group g's hit of the ray from pixel (x, y) goes in the output of
 * the pass (view after view, each width * height pixels row-major): into
 * g's view, at the pixel mirrored as g's slot says. */
RF_INLINE size_t rf_group_pixel_index(rf_i32 x, rf_i32 y, rf_u32 g, const rf_camera* cam) {
  const rf_u32 m = rf_group_mirror(g, cam);
  const rf_i32 px = (m & 1u) ? cam->xpair - x : x;
  const rf_i32 py = (m & 2u) ? cam->ypair - y : y;
  return rf_group_view_base(g, cam) + (size_t)(py * cam->width + px);
}

/* Writes the hit info of every pixel a ray answers: group g's hit goes to
 * its view's image, at the pixel mirrored as g says, with the depth of
 * rf_depth.h where the camera asks for it. depth_scales: one per view. */
RF_INLINE void rf_write_answers(const rf_camera_ray* ray, const rf_hit* hits, const rf_camera* cam,
                                const RF_GLOBAL float* depth_scales, const rf_depth_table* depths,
                                const RF_GLOBAL rf_tri* tris, const RF_GLOBAL rf_normal_xform* normal_xforms,
                                const rf_answers* out) {
  const float dz = -1.0f;
  const float len_d = cam->ortho ? 1.0f : RF_SQRT(ray->dx * ray->dx + ray->dy * ray->dy + dz * dz);
  const int exact_depth = (cam->write_flags & RF_WRITE_EXACT_DEPTH) != 0u;
  RF_FOR_EACH_GROUP(g, ray->groups) {
    const rf_u32 view = g >> cam->group_shift;
    const size_t at = rf_group_pixel_index(ray->x, ray->y, g, cam);
    rf_pixel_hit answer;
    rf_write_pixel(&answer, &hits[g], len_d, depth_scales[view], tris, normal_xforms, cam->write_flags);
    if (exact_depth && hits[g].instance != RF_INVALID) {
      const rf_u32 m = rf_group_mirror(g, cam);
      const rf_i32 px = (m & 1u) ? cam->xpair - ray->x : ray->x;
      const rf_i32 py = (m & 2u) ? cam->ypair - ray->y : ray->y;
      answer.z =
          rf_pixel_depth(depths, view, hits[g].instance, &tris[hits[g].tri], cam, px, py, depth_scales[view], answer.z);
    }
    rf_put_answer(out, at, &answer);
  }
}

/* Traces one entry of the compacted ray list and writes the hit info of every
 * pixel it answers (1, 2 or 4 per view). */
RF_INLINE void rf_trace_entry(rf_u32 entry, const rf_camera* cam, const RF_GLOBAL float* depth_scales,
                              const rf_depth_table* depths, const RF_GLOBAL rf_node* nodes,
                              const RF_GLOBAL rf_tri* tris, const RF_GLOBAL rf_instance* instances,
                              const RF_GLOBAL rf_normal_xform* normal_xforms, rf_u32 tlas_root,
                              const rf_answers* out RF_ALPHA_PARAM) {
  const rf_camera_ray ray = rf_decode_entry(entry, cam);
  rf_hit hits[RF_MAX_GROUPS];
  RF_FOR_EACH_GROUP(g, ray.groups) { rf_hit_reset(&hits[g]); }
  if (tlas_root != RF_INVALID)
    rf_trace_tlas(nodes, tris, instances, tlas_root, cam->ortho ? RF_ORIGIN_PLANE : RF_ORIGIN_EYE,
                  cam->ortho ? ray.dx : 0.0f, cam->ortho ? ray.dy : 0.0f, 0.0f, cam->ortho ? 0.0f : ray.dx,
                  cam->ortho ? 0.0f : ray.dy, -1.0f, 0.0f, 0, ray.groups, hits RF_ALPHA_ARG);
  rf_write_answers(&ray, hits, cam, depth_scales, depths, tris, normal_xforms, out);
}

/* Answers one ray query (scene.intersect, scene.occluded): its closest hit
 * with tmin < t <= tmax, or with any_hit the first one found, written as a
 * pixel's hit info with z = t along the given (unnormalised) direction.
 * `wide`, `tlas_wide` and `wide_roots` (device only, where the host always
 * gives them; null on the host, which walks the binary trees,
 * rf_trace_tlas): through the 8-wide trees at both levels
 * (rf_trace_query_tlas_wide), the same closest hits. With any_hit the hit found
 * first depends on the order, whether there is one does not (each
 * traversal enters every leaf whose box test passes at tmax until it finds
 * one). */
RF_INLINE void rf_trace_query(const RF_GLOBAL rf_query_ray* q, const RF_GLOBAL rf_node* nodes,
                              const RF_GLOBAL rf_wide8_node* wide, const RF_GLOBAL rf_wide8_node* tlas_wide,
                              rf_u32 tlas_wide_root, const RF_GLOBAL rf_u32* wide_roots, const RF_GLOBAL rf_tri* tris,
                              const RF_GLOBAL rf_instance* instances, const RF_GLOBAL rf_normal_xform* normal_xforms,
                              rf_u32 tlas_root, int any_hit, rf_u32 write_flags,
                              RF_GLOBAL rf_pixel_hit* out RF_ALPHA_PARAM) {
  rf_hit hit;
  rf_hit_reset(&hit);
  hit.t = q->tmax;
  if (tlas_root != RF_INVALID) {
#ifdef __OPENCL_C_VERSION__
    if (wide && tlas_wide)
      rf_trace_query_tlas_wide(nodes, wide, tlas_wide, tlas_wide_root, wide_roots, tris, instances, tlas_root, q->o[0],
                               q->o[1], q->o[2], q->d[0], q->d[1], q->d[2], q->tmin, any_hit, &hit RF_ALPHA_ARG);
    else
#else
    (void)wide;
    (void)tlas_wide;
    (void)tlas_wide_root;
    (void)wide_roots;
#endif
      rf_trace_tlas(nodes, tris, instances, tlas_root, RF_ORIGIN_ANY, q->o[0], q->o[1], q->o[2], q->d[0], q->d[1],
                    q->d[2], q->tmin, any_hit, 1u, &hit RF_ALPHA_ARG);
  }
  rf_pixel_hit answer;
  rf_write_pixel(&answer, &hit, 1.0f, 1.0f, tris, normal_xforms, write_flags);
  *out = answer;
}

#endif /* RF_TRACE_H */
