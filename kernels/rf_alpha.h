/* rf_alpha.h - alpha masks (glTF alphaMode MASK): whether a hit on a
 * masked triangle is kept, the same float operations on the device and in
 * the CPU reference, so that every backend sees through the same texels.
 *
 * A trace that reads masks is built with RF_ALPHA (the host defines it
 * only for a scene with a masked primitive): without it the parameters and
 * the test below compile to nothing, and a scene without masks traces with
 * the kernels it always had. The CPU reference always has them and passes
 * a null table for such a scene. */
#ifndef RF_ALPHA_H
#define RF_ALPHA_H

#ifndef __OPENCL_C_VERSION__
#include "rf_common.h"
#include "rf_types.h"
#define RF_ALPHA
#endif

/* The scene's masks as the trace reads them (rf_types.h's records). */
typedef struct {
  const RF_GLOBAL rf_u32* index; /* per triangle of the trees (rf_tri): its rf_alpha_tri, RF_INVALID: opaque */
  const RF_GLOBAL rf_alpha_tri* tris;
  const RF_GLOBAL rf_alpha_image* images;
  const RF_GLOBAL rf_u8* texels;
} rf_alpha_tables;

#ifdef RF_ALPHA
/* The extra parameter and argument of every function from the kernels down
 * to the triangle test, and the test itself where a hit is taken. */
#define RF_ALPHA_PARAM , const rf_alpha_tables* alpha
#define RF_ALPHA_ARG , alpha
#define RF_ALPHA_KEEPS(ti, u, v) &&(alpha == 0 || rf_alpha_keeps(alpha, ti, u, v))
#else
#define RF_ALPHA_PARAM
#define RF_ALPHA_ARG
#define RF_ALPHA_KEEPS(ti, u, v)
#endif

/* The texel index along one axis of n texels under coordinate s: the
 * nearest texel at level 0, floor(s n), wrapped as the sampler says. */
RF_INLINE rf_i32 rf_alpha_wrap(float s, rf_u32 n, rf_u32 mode) {
  float f = RF_FLOOR(s * (float)n);
  /* Within int range (and NaN to 0) before the conversion. */
  f = f > 16777216.0f ? 16777216.0f : (f < -16777216.0f ? -16777216.0f : (f == f ? f : 0.0f));
  const rf_i32 i = (rf_i32)f, size = (rf_i32)n;
  if (mode == RF_WRAP_CLAMP) return i < 0 ? 0 : (i >= size ? size - 1 : i);
  if (mode == RF_WRAP_MIRROR) {
    rf_i32 m = i % (2 * size);
    if (m < 0) m += 2 * size;
    return m < size ? m : 2 * size - 1 - m;
  }
  rf_i32 m = i % size;
  return m < 0 ? m + size : m;
}

/* Whether a hit at barycentrics (u, v) on the trees' triangle ti is kept:
 * 1 unless its primitive's material is MASK and its alpha there is below
 * alphaCutoff (glTF 3.9.4). The alpha is the corners' (b0 a0 + u a1) + v a2
 * with b0 = (1 - u) - v, times the base colour texture's alpha at the
 * interpolated texture coordinates: the nearest texel of level 0, wrapped,
 * its byte / 255. */
RF_INLINE int rf_alpha_keeps(const rf_alpha_tables* a, rf_u32 ti, float u, float v) {
  const rf_u32 record = a->index[ti];
  if (record == RF_INVALID) return 1;
  const RF_GLOBAL rf_alpha_tri* t = &a->tris[record];
  const float b0 = (1.0f - u) - v;
  float alpha = (b0 * t->alpha[0] + u * t->alpha[1]) + v * t->alpha[2];
  if (t->image != RF_INVALID) {
    const RF_GLOBAL rf_alpha_image* im = &a->images[t->image];
    const float s = (b0 * t->uv[0] + u * t->uv[2]) + v * t->uv[4];
    const float q = (b0 * t->uv[1] + u * t->uv[3]) + v * t->uv[5];
    const rf_i32 x = rf_alpha_wrap(s, im->width, im->wrap & 3u);
    const rf_i32 y = rf_alpha_wrap(q, im->height, (im->wrap >> 2) & 3u);
    alpha = alpha * ((float)a->texels[im->offset + (rf_u32)y * im->width + (rf_u32)x] * (1.0f / 255.0f));
  }
  return alpha >= t->cutoff;
}

#endif
