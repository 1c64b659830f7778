/* rf_geometry.h - ray set-up, ray-box, ray-triangle and the geometric normal.
 * Shared by the kernels and the CPU reference (see rf_common.h). */
#ifndef RF_GEOMETRY_H
#define RF_GEOMETRY_H

#ifndef __OPENCL_C_VERSION__
#include "rf_common.h"
#include "rf_types.h"
#endif

/* Box tests widen the slab interval by a few ulps in both directions so that
 * a node is never skipped while one of its triangles could still report a t
 * at or below the current bound. Rounding in the slab arithmetic is covered by
 * 1 + 2*gamma(3) (Ize 2013); the wider 2^-20 also covers the few ulps of error
 * in the triangle test's own t. Without it a near-tie could be found in one
 * traversal order and pruned in another, and folded output would differ. */
#define RF_BOX_NEAR_SCALE 0.99999905f /* 1 - 2^-20 */
#define RF_BOX_FAR_SCALE 1.00000095f  /* 1 + 2^-20 */

/* A ray with its per-ray data computed once: reciprocal direction for the
 * slab test, and the permutation and shear of the watertight triangle test. */
typedef struct {
  float o[3];
  float d[3];
  float invd[3];
  float sx, sy, sz;
  rf_i32 kx, ky, kz;
} rf_ray;

/* A zero direction component would give 0 * inf = NaN in the slab test, and
 * a subnormal one an infinite reciprocal with the same result; the smallest
 * normal float of the same sign stands in for them and keeps the test finite.
 * It is the float format's limit, not a length: no normal component is
 * touched, so the test does not depend on the scene's scale. Every kernel's
 * reciprocal uses this one constant. */
#define RF_RECIPROCAL_TINY 1.17549435e-38f /* FLT_MIN, 2^-126 */
RF_INLINE float rf_safe_reciprocal(float d) {
  const float tiny = RF_RECIPROCAL_TINY;
  return 1.0f / (RF_FABS(d) < tiny ? RF_COPYSIGN(tiny, d) : d);
}

RF_INLINE void rf_ray_init(rf_ray* r, float ox, float oy, float oz, float dx, float dy, float dz) {
  r->o[0] = ox;
  r->o[1] = oy;
  r->o[2] = oz;
  r->d[0] = dx;
  r->d[1] = dy;
  r->d[2] = dz;
  r->invd[0] = rf_safe_reciprocal(dx);
  r->invd[1] = rf_safe_reciprocal(dy);
  r->invd[2] = rf_safe_reciprocal(dz);
  /* Watertight test (Woop, Benthin, Wald 2013): z is the dominant axis; the
   * lowest index wins a tie so every compiler picks the same axis. */
  const float ax = RF_FABS(dx), ay = RF_FABS(dy), az = RF_FABS(dz);
  rf_i32 kz = 0;
  if (ay > ax) kz = 1;
  if (az > (kz == 0 ? ax : ay)) kz = 2;
  rf_i32 kx = kz + 1 == 3 ? 0 : kz + 1;
  rf_i32 ky = kx + 1 == 3 ? 0 : kx + 1;
  /* Swapping keeps the winding of the projected triangle consistent. */
  if (r->d[kz] < 0.0f) {
    const rf_i32 tmp = kx;
    kx = ky;
    ky = tmp;
  }
  r->kx = kx;
  r->ky = ky;
  r->kz = kz;
  /* From the reciprocal rather than three more divisions: a ray is set up
   * once per instance it enters, and the shear only has to be the same for
   * every triangle the ray meets, not correctly rounded. */
  r->sz = r->invd[kz];
  r->sx = r->d[kx] * r->sz;
  r->sy = r->d[ky] * r->sz;
}

/* Object-space ray of an instance: o = translation column, d = linear part
 * times the camera-space direction (the camera-space origin is the eye, 0).
 * No renormalisation, so t means the same in both spaces. */
RF_INLINE void rf_ray_to_object(rf_ray* out, const RF_GLOBAL float* m, float dx, float dy, float dz) {
  const float ox = m[3], oy = m[7], oz = m[11];
  const float ex = m[0] * dx + m[1] * dy + m[2] * dz;
  const float ey = m[4] * dx + m[5] * dy + m[6] * dz;
  const float ez = m[8] * dx + m[9] * dy + m[10] * dz;
  rf_ray_init(out, ox, oy, oz, ex, ey, ez);
}

/* The same for a ray from (ox, oy, 0) in trace space (orthographic): the
 * origin goes through the transform too. A mirrored copy's negated column
 * times a ray's origin is bit for bit the original column times the
 * partner's negated origin. */
RF_INLINE void rf_ray_to_object_from(rf_ray* out, const RF_GLOBAL float* m, float ox, float oy, float dx, float dy,
                                     float dz) {
  const float px = (m[0] * ox + m[1] * oy) + m[3];
  const float py = (m[4] * ox + m[5] * oy) + m[7];
  const float pz = (m[8] * ox + m[9] * oy) + m[11];
  const float ex = m[0] * dx + m[1] * dy + m[2] * dz;
  const float ey = m[4] * dx + m[5] * dy + m[6] * dz;
  const float ez = m[8] * dx + m[9] * dy + m[10] * dz;
  rf_ray_init(out, px, py, pz, ex, ey, ez);
}

/* The same for a ray from any trace-space point (ray queries). */
RF_INLINE void rf_ray_to_object_at(rf_ray* out, const RF_GLOBAL float* m, float ox, float oy, float oz, float dx,
                                   float dy, float dz) {
  const float px = ((m[0] * ox + m[1] * oy) + m[2] * oz) + m[3];
  const float py = ((m[4] * ox + m[5] * oy) + m[6] * oz) + m[7];
  const float pz = ((m[8] * ox + m[9] * oy) + m[10] * oz) + m[11];
  const float ex = m[0] * dx + m[1] * dy + m[2] * dz;
  const float ey = m[4] * dx + m[5] * dy + m[6] * dz;
  const float ez = m[8] * dx + m[9] * dy + m[10] * dz;
  rf_ray_init(out, px, py, pz, ex, ey, ez);
}

/* Slab test. Returns the (widened) entry distance, or RF_FAR when the ray misses
 * the box or enters it beyond tmax. A negative tmax means "skip". */
RF_INLINE float rf_intersect_box(const RF_GLOBAL rf_node* n, const rf_ray* r, float tmax) {
  const float tx0 = (n->bmin[0] - r->o[0]) * r->invd[0];
  const float tx1 = (n->bmax[0] - r->o[0]) * r->invd[0];
  const float ty0 = (n->bmin[1] - r->o[1]) * r->invd[1];
  const float ty1 = (n->bmax[1] - r->o[1]) * r->invd[1];
  const float tz0 = (n->bmin[2] - r->o[2]) * r->invd[2];
  const float tz1 = (n->bmax[2] - r->o[2]) * r->invd[2];
  const float tnear =
      rf_maxf(rf_maxf(rf_minf(tx0, tx1), rf_minf(ty0, ty1)), rf_maxf(rf_minf(tz0, tz1), 0.0f)) * RF_BOX_NEAR_SCALE;
  const float tfar = rf_minf(rf_minf(rf_maxf(tx0, tx1), rf_maxf(ty0, ty1)), rf_maxf(tz0, tz1)) * RF_BOX_FAR_SCALE;
  return tnear <= rf_minf(tfar, tmax) ? tnear : RF_FAR;
}

/* Whole-packet box test for rays that share one origin (primary rays, and
 * their object-space images under one instance): c0 = bmin - o and
 * c1 = bmax - o, lo[a] and hi[a] the smallest and largest reciprocal
 * direction among the packet's rays on axis a. Returns a lower bound on
 * every ray's rf_intersect_box entry distance, or RF_FAR when no ray of the
 * packet can pass rf_intersect_box with a tmax at or below `tmax`.
 * Why it is exact, not approximate: rounding is monotone, so for c >= 0 and
 * lo <= r <= hi, fl(c * lo) <= fl(c * r) <= fl(c * hi) (reversed for c < 0);
 * min, max and the multiplication by a positive constant keep the order. Each
 * ray's slab ends lie between these products, so its widened tnear is at
 * least the value returned here and its tfar at most the bound used here: a
 * rejected box is one that every ray's scalar test rejects too. */
RF_INLINE float rf_interval_box(const float c0[3], const float c1[3], const float lo[3], const float hi[3],
                                float tmax) {
  float near_lo[3], far_hi[3];
  for (int a = 0; a < 3; ++a) {
    const float p0 = c0[a] * lo[a], p1 = c0[a] * hi[a], p2 = c1[a] * lo[a], p3 = c1[a] * hi[a];
    near_lo[a] = rf_minf(rf_minf(p0, p1), rf_minf(p2, p3));
    far_hi[a] = rf_maxf(rf_maxf(p0, p1), rf_maxf(p2, p3));
  }
  const float tnear = rf_maxf(rf_maxf(near_lo[0], near_lo[1]), rf_maxf(near_lo[2], 0.0f)) * RF_BOX_NEAR_SCALE;
  const float tfar = rf_minf(rf_minf(far_hi[0], far_hi[1]), far_hi[2]) * RF_BOX_FAR_SCALE;
  /* Written so that a NaN rejects nothing. */
  return (tnear > tfar || tnear > tmax) ? RF_FAR : tnear;
}

/* Fills tri->n from its vertices: the unnormalised geometric normal, whose
 * edges are differences of tree-space vertices, so that it carries the
 * triangle's own rounding, not an origin's. Every rf_tri is made with it. */
RF_INLINE void rf_tri_set_normal(rf_tri* tri) {
  const float e1x = tri->v1[0] - tri->v0[0], e1y = tri->v1[1] - tri->v0[1], e1z = tri->v1[2] - tri->v0[2];
  const float e2x = tri->v2[0] - tri->v0[0], e2y = tri->v2[1] - tri->v0[1], e2z = tri->v2[2] - tri->v0[2];
  tri->n[0] = e1y * e2z - e1z * e2y;
  tri->n[1] = e1z * e2x - e1x * e2z;
  tri->n[2] = e1x * e2y - e1y * e2x;
}

/* The triangle's plane as the distance formula below reads it: n.(p - o) for
 * p the vertex nearest the origin o (smallest |p - o| summed over the axes,
 * the lowest vertex on a tie), which keeps the rounding of p - o small
 * against the plane's distance from o. One function for every kernel and the
 * CPU reference: the same floats in the same order. */
RF_INLINE float rf_plane_offset(const RF_GLOBAL rf_tri* tri, const float o[3]) {
  const float ax = tri->v0[0] - o[0], ay = tri->v0[1] - o[1], az = tri->v0[2] - o[2];
  const float bx = tri->v1[0] - o[0], by = tri->v1[1] - o[1], bz = tri->v1[2] - o[2];
  const float cx = tri->v2[0] - o[0], cy = tri->v2[1] - o[1], cz = tri->v2[2] - o[2];
  const float la = RF_FABS(ax) + RF_FABS(ay) + RF_FABS(az);
  const float lb = RF_FABS(bx) + RF_FABS(by) + RF_FABS(bz);
  const float lc = RF_FABS(cx) + RF_FABS(cy) + RF_FABS(cz);
  /* Selects, not branches: which vertex wins varies from triangle to triangle. */
  const int b_first = lb < la;
  const int c_first = lc < (b_first ? lb : la);
  const float px = c_first ? cx : (b_first ? bx : ax);
  const float py = c_first ? cy : (b_first ? by : ay);
  const float pz = c_first ? cz : (b_first ? bz : az);
  return tri->n[0] * px + tri->n[1] * py + tri->n[2] * pz;
}

/* Which distance formula a hit takes, from the vertices' depths along the
 * ray's dominant axis (vertex minus origin, axis kz): Woop's, a weighted
 * mean of those depths, is accurate when they are all on one side of the eye
 * and spread less than the nearest of them (a triangle small against its
 * distance: rounding of the weights moves t by a fraction of the spread);
 * the plane's is accurate when the plane does not pass close to the eye (a
 * large triangle near it, seen at an angle). Returns 1 for Woop's. */
RF_INLINE int rf_woop_distance_suits(float a_z, float b_z, float c_z) {
  const int one_side = (a_z > 0.0f && b_z > 0.0f && c_z > 0.0f) || (a_z < 0.0f && b_z < 0.0f && c_z < 0.0f);
  const float fa = RF_FABS(a_z), fb = RF_FABS(b_z), fc = RF_FABS(c_z);
  const float lo = rf_minf(rf_minf(fa, fb), fc), hi = rf_maxf(rf_maxf(fa, fb), fc);
  return one_side && hi - lo < lo;
}

/* Watertight ray-triangle test (Woop, Benthin, Wald 2013), without the double
 * fallback. Chosen because a ray through a shared edge or vertex can never
 * slip between the two triangles: each edge function is computed as
 * a*b - c*d, which the neighbouring triangle computes as c*d - a*b, the exact
 * negation in IEEE arithmetic, so the sign tests of both sides agree. It
 * accepts both windings (mirrored instances flip them) and rejects zero-area
 * triangles (det == 0) and NaN without producing a hit.
 * The distance is Woop's (the edge functions times the sheared vertex
 * depths over det) where rf_woop_distance_suits says so. Elsewhere, where a
 * large triangle passes close to the eye, those products are far larger
 * than their sum and cancel (up to 3e-4 relative on the Dabrovic Sponza's
 * floor), and it is the plane's, t = n.(p - o) / n.d with rf_plane_offset,
 * written with the shear (d = d[kz] (sx, sy, 1), sz = 1 / d[kz]) as
 * sz n.(p - o) / (n[kx] sx + n[ky] sy + n[kz]); Woop's again where that
 * denominator is 0 (a ray in the plane, as rounded).
 * Returns 1 with t, u (weight of v1), v (weight of v2) when the ray's line
 * meets the triangle; the caller checks t against its interval. */
/* The watertight test's first part, written once for one triangle (T
 * float) and for several side by side (T float8: rf_trace.h,
 * rf_leaf_candidates8), so that the vector sign tests are the scalar
 * test's operations by construction: the vertices relative to ray r's
 * origin (VERTEX(v0, axis) the coordinate `axis` of vertex v0), their
 * depths a_z, b_z, c_z kept for the distance, and the sheared edge
 * functions eu, ev, ew. */
#define RF_WATERTIGHT_EDGES(T, VERTEX, r)                                                                         \
  const rf_i32 kx = (r)->kx, ky = (r)->ky, kz = (r)->kz;                                                          \
  const T a_x = VERTEX(v0, kx) - (r)->o[kx], a_y = VERTEX(v0, ky) - (r)->o[ky], a_z = VERTEX(v0, kz) - (r)->o[kz]; \
  const T b_x = VERTEX(v1, kx) - (r)->o[kx], b_y = VERTEX(v1, ky) - (r)->o[ky], b_z = VERTEX(v1, kz) - (r)->o[kz]; \
  const T c_x = VERTEX(v2, kx) - (r)->o[kx], c_y = VERTEX(v2, ky) - (r)->o[ky], c_z = VERTEX(v2, kz) - (r)->o[kz]; \
  const T ax = a_x - (r)->sx * a_z, ay = a_y - (r)->sy * a_z;                                                     \
  const T bx = b_x - (r)->sx * b_z, by = b_y - (r)->sy * b_z;                                                     \
  const T cx = c_x - (r)->sx * c_z, cy = c_y - (r)->sy * c_z;                                                     \
  const T eu = cx * by - cy * bx;                                                                                 \
  const T ev = ax * cy - ay * cx;                                                                                 \
  const T ew = bx * ay - by * ax

RF_INLINE_ALWAYS int rf_intersect_triangle(const RF_GLOBAL rf_tri* tri, const rf_ray* r, float* t_out,
                                           float* u_out, float* v_out) {
#define RF_TRI_VERTEX(v, axis) tri->v[axis]
  RF_WATERTIGHT_EDGES(float, RF_TRI_VERTEX, r);
#undef RF_TRI_VERTEX
  if ((eu < 0.0f || ev < 0.0f || ew < 0.0f) && (eu > 0.0f || ev > 0.0f || ew > 0.0f)) return 0;
  const float det = eu + ev + ew;
  if (det == 0.0f) return 0;
  /* The plane's denominator only where its distance is taken; 0 picks Woop's. */
  const float den =
      rf_woop_distance_suits(a_z, b_z, c_z) ? 0.0f : tri->n[kx] * r->sx + tri->n[ky] * r->sy + tri->n[kz];
  if (den != 0.0f) {
    *t_out = (rf_plane_offset(tri, r->o) * r->sz) / den;
  } else {
    const float t_scaled = eu * (r->sz * a_z) + ev * (r->sz * b_z) + ew * (r->sz * c_z);
    *t_out = t_scaled / det;
  }
  *u_out = ev / det;
  *v_out = ew / det;
  return 1;
}

/* World-space unit geometric normal, cross(v1 - v0, v2 - v0) (tri->n) as wound in the
 * file, taken through the instance's normal matrix. Scaled by its largest
 * component before squaring so that large scenes cannot overflow. */
RF_INLINE void rf_geometric_normal(const RF_GLOBAL rf_tri* tri, const RF_GLOBAL rf_normal_xform* xf, float n[3]) {
  const float cx = tri->n[0], cy = tri->n[1], cz = tri->n[2];
  const RF_GLOBAL float* m = xf->m;
  float wx = m[0] * cx + m[1] * cy + m[2] * cz;
  float wy = m[3] * cx + m[4] * cy + m[5] * cz;
  float wz = m[6] * cx + m[7] * cy + m[8] * cz;
  const float big = rf_maxf(rf_maxf(RF_FABS(wx), RF_FABS(wy)), RF_FABS(wz));
  if (!(big > 0.0f)) {
    n[0] = 0.0f;
    n[1] = 0.0f;
    n[2] = 0.0f;
    return;
  }
  wx = wx / big;
  wy = wy / big;
  wz = wz / big;
  const float len = RF_SQRT(wx * wx + wy * wy + wz * wz);
  n[0] = wx / len;
  n[1] = wy / len;
  n[2] = wz / len;
}

#endif /* RF_GEOMETRY_H */
