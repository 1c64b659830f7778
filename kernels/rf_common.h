/* rf_common.h - the portability layer that lets one source compile as OpenCL C
 * (the device kernels) and as C++ (the host's CPU reference tracer).
 *
 * Why one source: the CPU reference must be the same algorithm as the kernel,
 * operation for operation, so that both produce the same bits. Writing it once
 * removes the chance of the two drifting apart; the parity tests then check
 * only what is left: how each compiler evaluates the float operations.
 *
 * Rules for code under kernels/:
 *  - plain C subset, scalar floats (no OpenCL vector types, no C++ features);
 *  - every float expression is written in the order it must be evaluated; no
 *    contraction to FMA (FP_CONTRACT OFF here, -ffp-contract=off on the host);
 *  - min/max only through rf_minf/rf_maxf, whose NaN behaviour is spelled out,
 *    never fmin/fmax (their NaN rules differ between libraries).
 */
#ifndef RF_COMMON_H
#define RF_COMMON_H

#ifdef __OPENCL_C_VERSION__
#ifndef RF_FAST_MATH /* the fast build lets the compiler contract and reorder */
#pragma OPENCL FP_CONTRACT OFF
#endif
typedef uint rf_u32;
typedef int rf_i32;
#define RF_GLOBAL __global
#define RF_INLINE inline
/* Inlined whatever the compiler's estimate: PoCL left the scalar
 * triangle test a call in the single-ray kernel, and inlining it made
 * scattered ray queries 1.02x to 1.16x faster (alternated runs, 1M rays,
 * 7 scene runs); always inlining every helper made the tile kernel 4% to
 * 11% slower. */
#define RF_INLINE_ALWAYS inline __attribute__((always_inline))
/* A call kept a call where the compiler is clang for a CPU (PoCL;
 * RF_CLANG_BUILTINS below): for code a kernel seldom runs whose inlined
 * body slowed the code around it. */
#ifdef RF_CLANG_BUILTINS
#define RF_NOINLINE __attribute__((noinline))
#else
#define RF_NOINLINE
#endif
#define RF_SQRT(x) sqrt(x)
/* Fused multiply-add, rounded once (double-float arithmetic, rf_depth.h). */
#define RF_FMA(a, b, c) fma(a, b, c)
#define RF_FABS(x) fabs(x)
#define RF_COPYSIGN(x, y) copysign(x, y)
#define RF_FLOOR(x) floor(x)
#define RF_INF INFINITY
typedef uchar rf_u8;
#else
#include <cmath>
#include <cstddef>
#include <cstdint>
typedef uint32_t rf_u32;
typedef int32_t rf_i32;
#define RF_GLOBAL
#define RF_INLINE static inline
#define RF_INLINE_ALWAYS static inline
#define RF_NOINLINE static
#define RF_SQRT(x) std::sqrt((float)(x))
#define RF_FMA(a, b, c) std::fma((float)(a), (float)(b), (float)(c))
#define RF_FABS(x) std::fabs((float)(x))
#define RF_COPYSIGN(x, y) std::copysign((float)(x), (float)(y))
#define RF_FLOOR(x) std::floor((float)(x))
#define RF_INF INFINITY
typedef uint8_t rf_u8;
#endif

/* Traversal counters for host diagnostics (tools/rayfold-stats); they compile
 * to nothing in the kernels and in the normal host build. */
#if defined(RF_TRAVERSAL_STATS) && !defined(__OPENCL_C_VERSION__)
typedef struct {
  unsigned long long tlas_nodes, instances, setups, blas_nodes, triangles;
} rf_traversal_stats;
extern thread_local rf_traversal_stats rf_stats;
#define RF_STAT(field) (++rf_stats.field)
#else
#define RF_STAT(field) ((void)0)
#endif

/* A hint to fetch the cache line at p, which the traversal reads soon:
 * nodes and triangles are visited in an order no hardware prefetcher
 * guesses, and their cache misses were a fifth of the tile kernel's time on
 * dense meshes. RF_CLANG_BUILTINS: the host says the kernels are compiled by
 * clang for a CPU (PoCL, whose OpenCL prefetch() does nothing), so clang's
 * builtins exist. A hint changes no result. RF_NO_PREFETCH (rayfold-peers
 * --ab-defines) turns the hints off, to measure what they buy on a machine. */
#if defined(RF_CLANG_BUILTINS) && defined(__OPENCL_C_VERSION__) && !defined(RF_NO_PREFETCH)
#define RF_PREFETCH_LINE(p) __builtin_prefetch(p)
#else
#define RF_PREFETCH_LINE(p) ((void)0)
#endif

/* The hint for every cache line of the bytes [first, end), end > first.
 * end - 1 too: a range that starts inside a line (56-byte triangles) can
 * end in a line the 64-byte steps pass over. */
RF_INLINE void rf_prefetch_bytes(const RF_GLOBAL char* first, const RF_GLOBAL char* end) {
  for (const RF_GLOBAL char* line = first; line < end; line += 64) RF_PREFETCH_LINE(line);
  RF_PREFETCH_LINE(end - 1);
}

/* "Nothing hit yet" and "box missed" inside the traversal: the largest
 * finite float, not +inf, because the fast build (-cl-fast-relaxed-math)
 * assumes finite math and may fold comparisons with infinity away. Only the
 * miss distance written to the output is +inf. */
#define RF_FAR 3.402823466e+38f

/* Marks "no hit" / "no node" in 32-bit index fields. */
#define RF_INVALID 0xFFFFFFFFu

/* Returns b when either argument is NaN: callers put the trusted value second. */
RF_INLINE float rf_minf(float a, float b) { return a < b ? a : b; }
RF_INLINE float rf_maxf(float a, float b) { return a > b ? a : b; }

#endif /* RF_COMMON_H */
