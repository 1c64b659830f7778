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

/* One 3x4 object_from_camera and one camera-space direction per case;
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
