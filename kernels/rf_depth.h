/* rf_depth.h - a camera hit's depth to within the float's last bit: the
 * distance along the pixel's exact ray (the double camera model, not the
 * float ray the traversal took) to the plane of the triangle the traversal
 * reports, computed in double-float arithmetic and rounded once.
 *
 * Why: the traversal's t comes from float inputs (the pixel's float
 * direction, its float transform into tree space, the triangle test's own
 * roundings), each off by about 2^-24 of its size. Where the ray grazes the
 * triangle, or the eye is far from the tree's origin against the hit's
 * distance, those relative errors grow by 1 / cos and by |origin| / t: the
 * depth tail (docs/results.md) was set by such pixels, in rayfold and in
 * Embree alike. Here every quantity carries about 48 bits (a float pair
 * hi + lo), so the result is off by far less than its own rounding.
 *
 * Exact: double-float uses only IEEE float +, -, * and fma (correctly
 * rounded in OpenCL and C++), so every device and the CPU reference give the
 * same bits. The depth is a function of the pixel, the view and the hit's
 * (instance, triangle), not of the ray that found it: a mirrored copy's hit
 * and an unfolded trace's give the same bits.
 *
 * The arithmetic is written once, for a type T, and made for scalars here
 * (the CPU reference and the single-ray kernel) and for lanes in rf_tile.h
 * (RF_DEPTH_DEFINE(rf_vf, v)). */
#ifndef RF_DEPTH_H
#define RF_DEPTH_H

#ifndef __OPENCL_C_VERSION__
#include "rf_common.h"
#include "rf_types.h"
#endif

/* What rf_pixel_depth reads: the pass's rf_depth_xform array and the
 * number of scene instances (the entries per view after its camera entry).
 * Read only by a camera trace with RF_WRITE_EXACT_DEPTH. */
typedef struct {
  const RF_GLOBAL rf_depth_xform* xforms;
  rf_u32 instances;
} rf_depth_table;

/* Double-float helpers and the depth, for a float type T (suffix S). Pairs
 * are (hi, lo) with |lo| <= ulp(hi) / 2; the sums are the "sloppy" ones,
 * whose error is about 2^-48 of their terms' size, ample where a dot product
 * cancels by the 1 / cos of a grazing ray (2^-48 * 10^4 is far below 2^-24). */
#define RF_DEPTH_DEFINE(T, S)                                                                    \
  RF_INLINE T rf_two_sum_##S(T a, T b, T* e) {                                                   \
    const T s = a + b;                                                                           \
    const T bb = s - a;                                                                          \
    *e = (a - (s - bb)) + (b - bb);                                                              \
    return s;                                                                                    \
  }                                                                                              \
  RF_INLINE T rf_fast_two_sum_##S(T a, T b, T* e) {                                              \
    const T s = a + b;                                                                           \
    *e = b - (s - a);                                                                            \
    return s;                                                                                    \
  }                                                                                              \
  RF_INLINE T rf_dd_add_##S(T ah, T al, T bh, T bl, T* lo) {                                     \
    T e;                                                                                         \
    const T s = rf_two_sum_##S(ah, bh, &e);                                                      \
    return rf_fast_two_sum_##S(s, e + (al + bl), lo);                                            \
  }                                                                                              \
  RF_INLINE T rf_dd_mul_##S(T ah, T al, T bh, T bl, T* lo) {                                     \
    const T p = ah * bh;                                                                         \
    T e = RF_FMA(ah, bh, -p);                                                                    \
    e = RF_FMA(ah, bl, e);                                                                       \
    e = RF_FMA(al, bh, e);                                                                       \
    return rf_fast_two_sum_##S(p, e, lo);                                                        \
  }                                                                                              \
  /* a . b for double-float 3-vectors (hi[3], lo[3] each). */                                    \
  RF_INLINE T rf_dd_dot_##S(const T* ah, const T* al, const T* bh, const T* bl, T* lo) {         \
    T l0, l1, l2, s0l;                                                                           \
    const T p0 = rf_dd_mul_##S(ah[0], al[0], bh[0], bl[0], &l0);                                 \
    const T p1 = rf_dd_mul_##S(ah[1], al[1], bh[1], bl[1], &l1);                                 \
    const T p2 = rf_dd_mul_##S(ah[2], al[2], bh[2], bl[2], &l2);                                 \
    const T s0 = rf_dd_add_##S(p0, l0, p1, l1, &s0l);                                            \
    return rf_dd_add_##S(s0, s0l, p2, l2, lo);                                                   \
  }                                                                                              \
  /* The part of a hit's depth that does not depend on the pixel: for the                        \
   * triangle v[0..8] (v0, v1, v2, tree space) and its instance's                                \
   * rf_depth_xform m in the view (24 values), with n the triangle's normal                      \
   * from its exact edges, the pairs (hi in pl[k], lo in pl[4 + k])                              \
   *   P = n.(v0 - o),  A = n.a,  B = n.b,  C = n.c.                                             \
   * The ray of the pixel with offsets (ix, iy) meets the plane                                  \
   * n.(p - v0) = 0 at t = (P - S) / C (orthographic) or P / (S + C)                             \
   * (perspective), S = A ix + B iy, t being the same parameter in every                         \
   * space (rf_depth_xform). */                                                                  \
  RF_INLINE void rf_depth_plane_##S(const T* v, const T* m, T* pl) {                             \
    T e1h[3], e1l[3], e2h[3], e2l[3], nh[3], nl[3], wh[3], wl[3];                                \
    for (int k = 0; k < 3; ++k) {                                                                \
      /* Edges of float vertices are exact as pairs. */                                          \
      e1h[k] = rf_two_sum_##S(v[3 + k], -v[k], &e1l[k]);                                         \
      e2h[k] = rf_two_sum_##S(v[6 + k], -v[k], &e2l[k]);                                         \
      wh[k] = rf_dd_add_##S(v[k], (T)(0.0f), -m[18 + k], -m[21 + k], &wl[k]);                    \
    }                                                                                            \
    for (int k = 0; k < 3; ++k) {                                                                \
      const int a = (k + 1) % 3, b = (k + 2) % 3;                                                \
      T ql, rl;                                                                                  \
      const T qh = rf_dd_mul_##S(e1h[a], e1l[a], e2h[b], e2l[b], &ql);                           \
      const T rh = rf_dd_mul_##S(e1h[b], e1l[b], e2h[a], e2l[a], &rl);                           \
      nh[k] = rf_dd_add_##S(qh, ql, -rh, -rl, &nl[k]);                                           \
    }                                                                                            \
    pl[0] = rf_dd_dot_##S(nh, nl, wh, wl, &pl[4]);                                               \
    pl[1] = rf_dd_dot_##S(nh, nl, m, m + 3, &pl[5]);                                             \
    pl[2] = rf_dd_dot_##S(nh, nl, m + 6, m + 9, &pl[6]);                                         \
    pl[3] = rf_dd_dot_##S(nh, nl, m + 12, m + 15, &pl[7]);                                       \
  }                                                                                              \
  /* |d_trace| of the pixel with offsets (ix, iy) (exact integers as                             \
   * floats), d_trace the camera entry cm's direction (along the camera's                        \
   * axis for planar), as a pair (hi returned, lo in *len_l). A function of                      \
   * (ix, iy) and cm alone: where cm's offsets (its c's x and y) are 0, as                       \
   * on every camera that folds, of (|ix|, |iy|), so mirror partners share it.                   \
   */                                                                                            \
  RF_INLINE T rf_depth_length_##S(const T* cm, T ix, T iy, int ortho, int planar, T* len_l) {    \
    if (planar || ortho) {                                                                       \
      /* Along the axis: the camera entry's -c.z, exact. */                                      \
      *len_l = (T)(0.0f);                                                                        \
      return -cm[14];                                                                            \
    }                                                                                            \
    T ul, wl, xl, yl, xxl, yyl, ql, rl;                                                          \
    const T uh = rf_dd_mul_##S(cm[0], cm[3], ix, (T)(0.0f), &ul);                                \
    const T wh = rf_dd_mul_##S(cm[7], cm[10], iy, (T)(0.0f), &wl);                               \
    const T xh = rf_dd_add_##S(uh, ul, cm[12], cm[15], &xl);                                     \
    const T yh = rf_dd_add_##S(wh, wl, cm[13], cm[16], &yl);                                     \
    const T xxh = rf_dd_mul_##S(xh, xl, xh, xl, &xxl);                                           \
    const T yyh = rf_dd_mul_##S(yh, yl, yh, yl, &yyl);                                           \
    const T qh = rf_dd_add_##S(xxh, xxl, yyh, yyl, &ql);                                         \
    const T rh = rf_dd_add_##S(qh, ql, cm[14] * cm[14], (T)(0.0f), &rl);                         \
    /* sqrt of a pair: one Newton step on the float root. */                                     \
    const T r = RF_SQRT(rh);                                                                     \
    const T rr = (RF_FMA(-r, r, rh) + rl) / (r + r);                                             \
    return rf_fast_two_sum_##S(r, rr, len_l);                                                    \
  }                                                                                              \
  /* The depth of the pixel with offsets (ix, iy) from its hit's                                 \
   * rf_depth_plane pl and its rf_depth_length (len_h, len_l): t |d_trace|,                      \
   * in trace units (the caller scales by the view's power of two); not                          \
   * finite or not positive where the ray runs in the plane. */                                  \
  RF_INLINE T rf_depth_finish_##S(const T* pl, T len_h, T len_l, T ix, T iy, int ortho) {        \
    T al, bl, sl, num_l, den_l;                                                                  \
    const T ah = rf_dd_mul_##S(pl[1], pl[5], ix, (T)(0.0f), &al);                                \
    const T bh = rf_dd_mul_##S(pl[2], pl[6], iy, (T)(0.0f), &bl);                                \
    const T sh = rf_dd_add_##S(ah, al, bh, bl, &sl);                                             \
    T num_h = pl[0], den_h = pl[3];                                                              \
    num_l = pl[4];                                                                               \
    den_l = pl[7];                                                                               \
    if (ortho)                                                                                   \
      num_h = rf_dd_add_##S(pl[0], pl[4], -sh, -sl, &num_l);                                     \
    else                                                                                         \
      den_h = rf_dd_add_##S(sh, sl, pl[3], pl[7], &den_l);                                       \
    T pl2;                                                                                       \
    const T ph = rf_dd_mul_##S(num_h, num_l, len_h, len_l, &pl2);                                \
    /* (ph, pl2) / (den_h, den_l): the float quotient and one correction. */                     \
    const T q = ph / den_h;                                                                      \
    T el;                                                                                        \
    const T eh = rf_dd_mul_##S(q, (T)(0.0f), den_h, den_l, &el);                                 \
    const T rest = ((ph - eh) - el) + pl2;                                                       \
    return q + rest / den_h;                                                                     \
  }

RF_DEPTH_DEFINE(float, f)

/* Whether the double-float depth e replaces the float depth z: finite,
 * positive and within 2^-8 of z. Further off, the exact ray meets the plane
 * far from where the float ray met the triangle (a ray within about 1e-5
 * of the plane, whose exact ray may pass outside the triangle): the float
 * depth of the triangle the traversal reported is kept. The corrections
 * measured on grazing pixels were below 2^-12 (docs/results.md). */
RF_INLINE int rf_depth_plausible(float e, float z) {
  return e > 0.0f && e < RF_FAR && RF_FABS(e - z) <= z * 0x1p-8f;
}

/* The table entry of a hit: its scene instance less its triangle's offset
 * in a merged tree, i.e. the tree's first member, whose entry every member
 * shares (their transforms are the same, bit for bit: bvh/scene_data.cpp). */
RF_INLINE rf_u32 rf_depth_key(rf_u32 instance, const RF_GLOBAL rf_tri* tri) { return instance - tri->inst; }

/* The depth of pixel (px, py) of view `view` on hit triangle `tri` of scene
 * instance `instance`, in world units, from the table (rf_depth_xform); the
 * float depth z where the double-float one is not plausible
 * (rf_depth_plausible). */
RF_INLINE float rf_pixel_depth(const rf_depth_table* dt, rf_u32 view, rf_u32 instance, const RF_GLOBAL rf_tri* tri,
                               const rf_camera* cam, rf_i32 px, rf_i32 py, float depth_scale, float z) {
  const RF_GLOBAL rf_depth_xform* cam_xf = &dt->xforms[(size_t)view * (dt->instances + 1u)];
  const RF_GLOBAL rf_depth_xform* xf = cam_xf + 1u + rf_depth_key(instance, tri);
  float v[9], m[24], cm[24], pl[8];
  for (int k = 0; k < 3; ++k) {
    v[k] = tri->v0[k];
    v[3 + k] = tri->v1[k];
    v[6 + k] = tri->v2[k];
  }
  for (int k = 0; k < 24; ++k) {
    m[k] = xf->m[k];
    cm[k] = cam_xf->m[k];
  }
  rf_depth_plane_f(v, m, pl);
  const float ix = (float)(2 * px + cam->kx0), iy = (float)(cam->ky0 - 2 * py);
  float len_l;
  const float len_h =
      rf_depth_length_f(cm, ix, iy, cam->ortho, (cam->write_flags & RF_WRITE_PLANAR_DEPTH) != 0u, &len_l);
  const float d = rf_depth_finish_f(pl, len_h, len_l, ix, iy, cam->ortho);
  const float e = d * depth_scale;
  return rf_depth_plausible(e, z) ? e : z;
}

#endif /* RF_DEPTH_H */
