/* rf_lanes.h - SIMD across rays: one ray per lane of an OpenCL vector.
 * Device only (OpenCL C vector types); the tile kernel (rf_tile.h) is built
 * on it.
 *
 * Every lane evaluates exactly the float operations of the scalar code in
 * rf_geometry.h, in the same order, so a lane's results are the scalar
 * code's bits: the vector operations are IEEE per component, FP_CONTRACT is
 * off and division is correctly rounded in the exact build. Nothing here
 * combines two lanes' values except the reductions, which only decide what to
 * visit, never what a lane computes.
 */
#ifndef RF_LANES_H
#define RF_LANES_H

/* Lanes per vector: 16 fills two AVX2 registers or one AVX-512 register; 8
 * one AVX2 register. The host may override it at build time. */
#ifndef RF_LANES
#define RF_LANES 16
#endif

#if RF_LANES == 16
typedef float16 rf_vf;
typedef int16 rf_vi;
typedef uint16 rf_vu;
#define rf_lanes_load_u vload16 /* RF_LANES consecutive rf_u32 as rf_vu */
#define rf_lanes_load_i vload16 /* RF_LANES consecutive ints as rf_vi */
#define rf_lanes_store_u vstore16
#define rf_lanes_as_vi as_int16
#define rf_lanes_as_vu as_uint16
#define rf_lanes_to_vf convert_float16 /* each int to the nearest float, as (float) does */
#elif RF_LANES == 8
typedef float8 rf_vf;
typedef int8 rf_vi;
typedef uint8 rf_vu;
#define rf_lanes_load_u vload8
#define rf_lanes_load_i vload8
#define rf_lanes_store_u vstore8
#define rf_lanes_as_vi as_int8
#define rf_lanes_as_vu as_uint8
#define rf_lanes_to_vf convert_float8
#else
#error "RF_LANES must be 8 or 16"
#endif

/* The OR of every lane (reductions of bit sets only). */
RF_INLINE rf_u32 rf_lanes_or(rf_vu v) {
#if RF_LANES == 16
  const uint8 a = v.lo | v.hi;
  const uint4 b = a.lo | a.hi;
#else
  const uint4 b = v.lo | v.hi;
#endif
  const uint2 c = b.lo | b.hi;
  return c.x | c.y;
}

/* Any lane set (a lane of a comparison mask is -1 or 0): any lane's sign
 * bit. PoCL compiles the built-in any() on wide vectors to a chain of
 * shuffles and branches; clang's reduction (where no instruction below
 * applies) is shorter, else an OR tree by hand. Eight lanes with AVX
 * (PoCL's AVX2 devices): the sign bits tested in one instruction (vtestps),
 * where LLVM made the reduction a pack, a
 * shift and a byte mask on the path from each test to its branch (random
 * views 1.03x to 1.05x faster on all seven scenes with movmskps, for which
 * LLVM still narrowed the masks of the triangle test first; vtestps
 * another 1.02x to 1.06x). */
RF_INLINE int rf_lanes_any(rf_vi m) {
#if defined(RF_CLANG_BUILTINS) && defined(__AVX__) && RF_LANES == 8
  return !__builtin_ia32_vtestzps256(as_float8(m), as_float8(m));
#elif defined(RF_CLANG_BUILTINS) && defined(__AVX512DQ__) && RF_LANES == 16
  /* Sixteen lanes with AVX-512: the sign bits into a mask register in one
   * instruction (vpmovd2m), tested there. LLVM lowered the reduction below
   * as a tree of extracts, shuffles and ORs into a general register (eight
   * instructions on the path from each test to its branch; the triangle
   * test's hottest instructions on the dragon), where a mask that came from
   * a comparison had been moved into a vector first. */
  return __builtin_ia32_cvtd2mask512(m) != 0;
#elif defined(RF_CLANG_BUILTINS)
  return __builtin_reduce_or(m) < 0;
#else
  return (rf_lanes_or(rf_lanes_as_vu(m)) >> 31) != 0u;
#endif
}

/* rf_minf and rf_maxf lane by lane, with the same NaN rule (b wins). */
RF_INLINE rf_vf rf_lanes_min(rf_vf a, rf_vf b) { return select(b, a, a < b); }
RF_INLINE rf_vf rf_lanes_max(rf_vf a, rf_vf b) { return select(b, a, a > b); }

/* Smallest and largest lane (reductions only bound what a packet visits). */
RF_INLINE float rf_lanes_hmin(rf_vf v) {
#if RF_LANES == 16
  const float8 a = fmin(v.lo, v.hi);
  const float4 b = fmin(a.lo, a.hi);
#else
  const float4 b = fmin(v.lo, v.hi);
#endif
  const float2 c = fmin(b.lo, b.hi);
  return fmin(c.x, c.y);
}
RF_INLINE float rf_lanes_hmax(rf_vf v) {
#if RF_LANES == 16
  const float8 a = fmax(v.lo, v.hi);
  const float4 b = fmax(a.lo, a.hi);
#else
  const float4 b = fmax(v.lo, v.hi);
#endif
  const float2 c = fmax(b.lo, b.hi);
  return fmax(c.x, c.y);
}

/* rf_safe_reciprocal lane by lane. */
RF_INLINE rf_vf rf_lanes_reciprocal(rf_vf d) {
  const float tiny = RF_RECIPROCAL_TINY;
  return 1.0f / select(d, copysign((rf_vf)(tiny), d), fabs(d) < (rf_vf)(tiny));
}

/* One component of a lane's permuted vector: v[k] for the lane's k. */
RF_INLINE rf_vf rf_lanes_pick_v(rf_vf v0, rf_vf v1, rf_vf v2, rf_vi k) {
  return select(select(v0, v1, k == 1), v2, k == 2);
}
RF_INLINE rf_vf rf_lanes_pick(float v0, float v1, float v2, rf_vi k) {
  return rf_lanes_pick_v((rf_vf)(v0), (rf_vf)(v1), (rf_vf)(v2), k);
}

/* rf_intersect_box's slab ends for rays sharing one origin: c0 = bmin - o
 * and c1 = bmax - o are the same for every lane, so only the products are
 * per lane. Returns the widened entry, *tfar the widened exit. */
RF_INLINE rf_vf rf_lanes_slab(const float c0[3], const float c1[3], rf_vf ix, rf_vf iy, rf_vf iz, rf_vf* tfar) {
  const rf_vf tx0 = c0[0] * ix, tx1 = c1[0] * ix;
  const rf_vf ty0 = c0[1] * iy, ty1 = c1[1] * iy;
  const rf_vf tz0 = c0[2] * iz, tz1 = c1[2] * iz;
  *tfar = rf_lanes_min(rf_lanes_min(rf_lanes_max(tx0, tx1), rf_lanes_max(ty0, ty1)), rf_lanes_max(tz0, tz1)) *
          RF_BOX_FAR_SCALE;
  return rf_lanes_max(rf_lanes_max(rf_lanes_min(tx0, tx1), rf_lanes_min(ty0, ty1)),
                      rf_lanes_max(rf_lanes_min(tz0, tz1), (rf_vf)(0.0f))) *
         RF_BOX_NEAR_SCALE;
}
/* rf_intersect_box lane by lane: the mask of lanes that pass. */
RF_INLINE rf_vi rf_lanes_box(const float c0[3], const float c1[3], rf_vf ix, rf_vf iy, rf_vf iz, rf_vf tmax) {
  rf_vf tfar;
  const rf_vf tnear = rf_lanes_slab(c0, c1, ix, iy, iz, &tfar);
  return tnear <= rf_lanes_min(tfar, tmax);
}
/* The same test returning what rf_intersect_box returns: each lane's
 * entry distance, or RF_FAR where the lane does not pass. */
RF_INLINE rf_vf rf_lanes_box_entry(const float c0[3], const float c1[3], rf_vf ix, rf_vf iy, rf_vf iz, rf_vf tmax) {
  rf_vf tfar;
  const rf_vf tnear = rf_lanes_slab(c0, c1, ix, iy, iz, &tfar);
  return select((rf_vf)(RF_FAR), tnear, tnear <= rf_lanes_min(tfar, tmax));
}

/* rf_woop_distance_suits lane by lane. */
RF_INLINE rf_vi rf_lanes_woop_suits(rf_vf a_z, rf_vf b_z, rf_vf c_z) {
  const rf_vf zero = (rf_vf)(0.0f);
  const rf_vi one_side = ((a_z > zero) & (b_z > zero) & (c_z > zero)) | ((a_z < zero) & (b_z < zero) & (c_z < zero));
  const rf_vf fa = fabs(a_z), fb = fabs(b_z), fc = fabs(c_z);
  const rf_vf lo = rf_lanes_min(rf_lanes_min(fa, fb), fc), hi = rf_lanes_max(rf_lanes_max(fa, fb), fc);
  return one_side & (hi - lo < lo);
}

/* rf_intersect_triangle lane by lane. a, b, c are the vertices minus the
 * shared origin, already permuted by each lane's (kx, ky, kz), and nx, ny, nz
 * the triangle's normal permuted the same way; woop is
 * rf_woop_distance_suits of each lane, and offset rf_plane_offset (needed
 * only where woop is not set). Returns the mask of lanes whose line meets
 * the triangle, with t for every lane and the edge functions ev, ew and det
 * that give u and v when a hit is taken. */
RF_INLINE rf_vi rf_lanes_triangle(rf_vf a_x, rf_vf a_y, rf_vf a_z, rf_vf b_x, rf_vf b_y, rf_vf b_z, rf_vf c_x,
                                  rf_vf c_y, rf_vf c_z, rf_vf sx, rf_vf sy, rf_vf sz, rf_vf nx, rf_vf ny, rf_vf nz,
                                  rf_vi woop, float offset, rf_vf* t_out, rf_vf* ev_out, rf_vf* ew_out,
                                  rf_vf* det_out) {
  const rf_vf ax = a_x - sx * a_z, ay = a_y - sy * a_z;
  const rf_vf bx = b_x - sx * b_z, by = b_y - sy * b_z;
  const rf_vf cx = c_x - sx * c_z, cy = c_y - sy * c_z;
  const rf_vf eu = cx * by - cy * bx;
  const rf_vf ev = ax * cy - ay * cx;
  const rf_vf ew = bx * ay - by * ax;
  const rf_vf zero = (rf_vf)(0.0f);
  const rf_vi neg = (eu < zero) | (ev < zero) | (ew < zero);
  const rf_vi pos = (eu > zero) | (ev > zero) | (ew > zero);
  const rf_vf det = eu + ev + ew;
  const rf_vi ok = ~(neg & pos) & (det != zero);
  if (!rf_lanes_any(ok)) return ok;
  rf_vf t = zero;
  if (rf_lanes_any(ok & ~woop)) {
    const rf_vf den = nx * sx + ny * sy + nz;
    t = ((rf_vf)(offset) * sz) / den;
    woop |= den == zero;
  }
  if (rf_lanes_any(ok & woop)) {
    const rf_vf t_scaled = eu * (sz * a_z) + ev * (sz * b_z) + ew * (sz * c_z);
    t = select(t, t_scaled / det, woop);
  }
  *t_out = t;
  *ev_out = ev;
  *ew_out = ew;
  *det_out = det;
  return ok;
}

#endif /* RF_LANES_H */
