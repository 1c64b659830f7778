/* rf_unit_tests.cl - wrappers that run single shared functions on the device,
 * one work-item per test case, so tests/ can compare them with the host's
 * compilation of the same functions. Built only by the tests. */

/* ray: 6 floats (origin, direction) per case; out: the rf_ray fields. */
__kernel void ut_ray_init(__global const float* ray, __global float* out) {
  const uint i = get_global_id(0);
  __global const float* a = ray + 6 * i;
  rf_ray r;
  rf_ray_init(&r, a[0], a[1], a[2], a[3], a[4], a[5]);
  __global float* o = out + 15 * i;
  for (int k = 0; k < 3; ++k) {
    o[k] = r.invd[k];
  }
  o[3] = r.sx;
  o[4] = r.sy;
  o[5] = r.sz;
  o[6] = (float)r.kx;
  o[7] = (float)r.ky;
  o[8] = (float)r.kz;
  for (int k = 0; k < 3; ++k) {
    o[9 + k] = r.o[k];
    o[12 + k] = r.d[k];
  }
}

/* One box and one ray (6 floats) per case; out: entry distance or RF_FAR. */
__kernel void ut_ray_box(__global const rf_node* boxes, __global const float* ray, __global const float* tmax,
                         __global float* out) {
  const uint i = get_global_id(0);
  __global const float* a = ray + 6 * i;
  rf_ray r;
  rf_ray_init(&r, a[0], a[1], a[2], a[3], a[4], a[5]);
  out[i] = rf_intersect_box(&boxes[i], &r, tmax[i]);
}

/* One triangle and one ray per case; out: hit flag, t, u, v. */
__kernel void ut_ray_triangle(__global const rf_tri* tris, __global const float* ray, __global float* out) {
  const uint i = get_global_id(0);
  __global const float* a = ray + 6 * i;
  rf_ray r;
  rf_ray_init(&r, a[0], a[1], a[2], a[3], a[4], a[5]);
  float t = 0.0f, u = 0.0f, v = 0.0f;
  const int hit = rf_intersect_triangle(&tris[i], &r, &t, &u, &v);
  out[4 * i + 0] = (float)hit;
  out[4 * i + 1] = hit ? t : 0.0f;
  out[4 * i + 2] = hit ? u : 0.0f;
  out[4 * i + 3] = hit ? v : 0.0f;
}

/* One 3x4 tree_from_trace and one camera-space direction per case;
 * out: the object-space ray's origin and direction. */
__kernel void ut_transform(__global const float* xf, __global const float* dir, __global float* out) {
  const uint i = get_global_id(0);
  rf_ray r;
  rf_ray_to_object(&r, xf + 12 * i, dir[3 * i], dir[3 * i + 1], dir[3 * i + 2]);
  for (int k = 0; k < 3; ++k) {
    out[6 * i + k] = r.o[k];
    out[6 * i + 3 + k] = r.d[k];
  }
}

/* One triangle and one normal matrix per case; out: the unit normal. */
__kernel void ut_normal(__global const rf_tri* tris, __global const rf_normal_xform* xf, __global float* out) {
  const uint i = get_global_id(0);
  float n[3];
  rf_geometric_normal(&tris[i], &xf[i], n);
  out[3 * i + 0] = n[0];
  out[3 * i + 1] = n[1];
  out[3 * i + 2] = n[2];
}

/* The tile kernel's pieces (rf_tile.h), one tile of RF_TILE_RAYS lanes per
 * case: dirs holds the case's camera-space dx, dy per lane (dz = -1), xf its
 * 3x4 tree_from_trace. */
RF_INLINE void ut_tile_rays(__global const float* xf, __global const float* dirs, rf_tile_camera* tc, rf_tile_ray* r) {
  float* dx = (float*)tc->dx;
  float* dy = (float*)tc->dy;
  for (int l = 0; l < RF_TILE_RAYS; ++l) {
    dx[l] = dirs[2 * l];
    dy[l] = dirs[2 * l + 1];
  }
  r->valid = 0;
  rf_tile_to_object(r, xf, tc, 0);
}

/* out per lane: invd[3], sx, sy, sz, kx, ky, kz; then lo[3], hi[3], uniform. */
__kernel void ut_tile_to_object(__global const float* xf, __global const float* dirs, __global float* out) {
  const uint i = get_global_id(0);
  rf_tile_camera tc;
  rf_tile_ray r;
  ut_tile_rays(xf + 12 * i, dirs + 2 * RF_TILE_RAYS * i, &tc, &r);
  __global float* o = out + (9 * RF_TILE_RAYS + 7) * i;
  for (int l = 0; l < RF_TILE_RAYS; ++l) {
    o[9 * l + 0] = ((const float*)r.ix)[l];
    o[9 * l + 1] = ((const float*)r.iy)[l];
    o[9 * l + 2] = ((const float*)r.iz)[l];
    o[9 * l + 3] = ((const float*)r.sx)[l];
    o[9 * l + 4] = ((const float*)r.sy)[l];
    o[9 * l + 5] = ((const float*)r.sz)[l];
    o[9 * l + 6] = (float)(r.uniform ? r.kx : ((const int*)r.pkx)[l]);
    o[9 * l + 7] = (float)(r.uniform ? r.ky : ((const int*)r.pky)[l]);
    o[9 * l + 8] = (float)(r.uniform ? r.kz : ((const int*)r.pkz)[l]);
  }
  for (int k = 0; k < 3; ++k) {
    o[9 * RF_TILE_RAYS + k] = r.lo[k];
    o[9 * RF_TILE_RAYS + 3 + k] = r.hi[k];
  }
  o[9 * RF_TILE_RAYS + 6] = (float)r.uniform;
}

/* One box and a tmax per lane; out per lane: the entry distance
 * (rf_lanes_box_entry), RF_FAR where the lane's slab test fails, which
 * rf_lanes_box must say too (else NaN, a certain mismatch). */
__kernel void ut_tile_box(__global const rf_node* boxes, __global const float* xf, __global const float* dirs,
                          __global const float* tmax, __global float* out) {
  const uint i = get_global_id(0);
  rf_tile_camera tc;
  rf_tile_ray r;
  ut_tile_rays(xf + 12 * i, dirs + 2 * RF_TILE_RAYS * i, &tc, &r);
  __global const rf_node* n = &boxes[i];
  const float c0[3] = {n->bmin[0] - r.o[0], n->bmin[1] - r.o[1], n->bmin[2] - r.o[2]};
  const float c1[3] = {n->bmax[0] - r.o[0], n->bmax[1] - r.o[1], n->bmax[2] - r.o[2]};
  for (int j = 0; j < RF_LANE_GROUPS; ++j) {
    float tm[RF_LANES];
    for (int l = 0; l < RF_LANES; ++l) tm[l] = tmax[RF_TILE_RAYS * i + RF_LANES * j + l];
    const rf_vi m = rf_lanes_box(c0, c1, r.ix[j], r.iy[j], r.iz[j], *(const rf_vf*)tm);
    const rf_vf e = rf_lanes_box_entry(c0, c1, r.ix[j], r.iy[j], r.iz[j], *(const rf_vf*)tm);
    for (int l = 0; l < RF_LANES; ++l) {
      const float entry = ((const float*)&e)[l];
      const int agree = (((const int*)&m)[l] < 0) == (entry != RF_FAR);
      out[RF_TILE_RAYS * i + RF_LANES * j + l] = agree ? entry : NAN;
    }
  }
}

/* One triangle per case, taken by every lane that hits it (rf_tile_triangle
 * from an empty hit record); out per lane: hit, t, u, v. */
__kernel void ut_tile_triangle(__global const rf_tri* tris, __global const float* xf, __global const float* dirs,
                               __global float* out) {
  const uint i = get_global_id(0);
  rf_tile_camera tc;
  rf_tile_ray r;
  ut_tile_rays(xf + 12 * i, dirs + 2 * RF_TILE_RAYS * i, &tc, &r);
  rf_tile_hits h;
  rf_vi all[RF_LANE_GROUPS];
  rf_vf leaf_t[RF_LANE_GROUPS];
  for (int j = 0; j < RF_LANE_GROUPS; ++j) {
    leaf_t[j] = (rf_vf)(0.0f);
    h.t[j] = (rf_vf)(RF_FAR);
    h.u[j] = h.v[j] = (rf_vf)(0.0f);
    h.instance[j] = h.prim[j] = h.tri[j] = (rf_vu)(RF_INVALID);
    all[j] = (rf_vi)(-1);
  }
  rf_tile_triangle(&tris[i], 0u, &r, 0u, 0xFFFFFFFFu >> (32 - RF_LANE_GROUPS), all, leaf_t, 0, &h);
  for (int l = 0; l < RF_TILE_RAYS; ++l) {
    const int hit = ((const rf_u32*)h.tri)[l] != RF_INVALID;
    __global float* o = out + 4 * (RF_TILE_RAYS * i + l);
    o[0] = (float)hit;
    o[1] = hit ? ((const float*)h.t)[l] : 0.0f;
    o[2] = hit ? ((const float*)h.u)[l] : 0.0f;
    o[3] = hit ? ((const float*)h.v)[l] : 0.0f;
  }
}

/* One mask of eight lanes per case (bit k: lane k true); out: rf_lane_bits8
 * of the comparison whose result it is. */
__kernel void ut_lane_bits8(__global const uint* masks, __global uint* out) {
  const uint i = get_global_id(0);
  const int8 lanes = (int8)(0, 1, 2, 3, 4, 5, 6, 7);
  const int8 set = (((int8)((int)masks[i]) >> lanes) & (int8)(1)) != (int8)(0);
  out[i] = rf_lane_bits8(set);
}

/* out[0]: 1 where rf_lane_bits8 takes clang's sign-bit instruction. */
__kernel void ut_lane_bits_path(__global uint* out) {
#if defined(RF_CLANG_BUILTINS) && defined(__AVX__)
  out[0] = 1u;
#else
  out[0] = 0u;
#endif
}

/* RF_LANES ints per case (a lane vector, any values); out: rf_lanes_any of it. */
__kernel void ut_lanes_any(__global const int* lanes, __global uint* out) {
  const uint i = get_global_id(0);
  out[i] = (uint)rf_lanes_any(rf_lanes_load_i(i, lanes));
}

/* out[0]: the path rf_lanes_any takes in this build (2: the sign bits
 * tested in one instruction, 1: clang's reduction, 0: the OR tree); out[1]: RF_LANES. */
__kernel void ut_lanes_any_path(__global uint* out) {
#if defined(RF_CLANG_BUILTINS) && defined(__AVX__) && RF_LANES == 8
  out[0] = 2u;
#elif defined(RF_CLANG_BUILTINS) && defined(__AVX512DQ__) && RF_LANES == 16
  out[0] = 2u;
#elif defined(RF_CLANG_BUILTINS)
  out[0] = 1u;
#else
  out[0] = 0u;
#endif
  out[1] = RF_LANES;
}
