// Single shared functions run on the OpenCL device (rf_unit_tests.cl) must
// give the host compilation's bits exactly, on random and edge-case inputs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "opencl/kernel_sources.h"
#include "rf_trace.h"
#include "rf_types.h"
#include "test_util.h"

namespace rayfold::core {
namespace {

using testing::Rng;

// What this CPU has of the ISAs where PoCL (whose device is this CPU)
// compiles the kernels' sign-bit instructions: AVX (vtestps, movmskps on
// 8 lanes), AVX-512 DQ (vpmovd2m on 16).
struct HostIsa {
  bool avx = false, avx512dq = false;
};
HostIsa host_isa() {
  HostIsa h;
#if defined(__x86_64__) || defined(__i386__)
  h.avx = __builtin_cpu_supports("avx");
  h.avx512dq = __builtin_cpu_supports("avx512dq");
#endif
  return h;
}
bool host_has_avx() { return host_isa().avx; }

class KernelUnits : public ::testing::Test {
 protected:
  // A program that does not build fails every test, saying why (thrown
  // from SetUpTestSuite, gtest reported the tests as skipped, and ctest
  // passed them, when a kernel signature changed under them).
  static void SetUpTestSuite() {
    try {
      program_ = new cl::Program(testing::test_device().build(unit_test_program_source(), KernelPrecision::exact));
    } catch (const std::exception& e) {
      build_error_ = e.what();
    }
  }
  static void TearDownTestSuite() {
    delete program_;
    program_ = nullptr;
  }
  void SetUp() override {
    if (!program_) FAIL() << "the unit-test kernels do not build: " << build_error_;
  }

  template <class T>
  cl::Buffer in(const std::vector<T>& v) {
    return cl::Buffer(testing::test_device().context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, v.size() * sizeof(T),
                      const_cast<T*>(v.data()));
  }
  cl::Buffer out(size_t floats) {
    return cl::Buffer(testing::test_device().context(), CL_MEM_WRITE_ONLY, floats * sizeof(float));
  }
  std::vector<float> run(const char* name, std::vector<cl::Buffer> args, size_t n, size_t out_floats) {
    cl::Kernel k(*program_, name);
    for (size_t i = 0; i < args.size(); ++i) k.setArg(static_cast<cl_uint>(i), args[i]);
    cl::CommandQueue& q = testing::test_device().queue();
    q.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(n));
    std::vector<float> result(out_floats);
    q.enqueueReadBuffer(args.back(), CL_TRUE, 0, out_floats * sizeof(float), result.data());
    return result;
  }

  // Random rays with edge cases mixed in: zero and negative-zero components,
  // axis-aligned directions, tiny and huge magnitudes.
  static std::vector<float> rays(Rng& rng, size_t n) {
    std::vector<float> r(6 * n);
    for (size_t i = 0; i < n; ++i) {
      for (int k = 0; k < 6; ++k) r[6 * i + k] = rng.uniformf(-2, 2);
      switch (i % 8) {
        case 0: r[6 * i + 3] = 0.0f; break;
        case 1:
          r[6 * i + 4] = -0.0f;
          r[6 * i + 5] = 0.0f;
          break;
        case 2: r[6 * i + 3] = 1e-35f; break;
        case 3: r[6 * i + 5] = 1e20f; break;
        case 4:
          r[6 * i + 3] = r[6 * i + 4];
          r[6 * i + 5] = r[6 * i + 4];
          break;  // |dx|=|dy|=|dz| tie
        default: break;
      }
    }
    return r;
  }

  static cl::Program* program_;
  static std::string build_error_;
};

cl::Program* KernelUnits::program_ = nullptr;
std::string KernelUnits::build_error_;

void expect_bits_equal(const std::vector<float>& host, const std::vector<float>& device, const char* what) {
  ASSERT_EQ(host.size(), device.size());
  size_t bad = 0;
  for (size_t i = 0; i < host.size(); ++i)
    if (std::memcmp(&host[i], &device[i], 4) != 0 && bad++ < 5)
      ADD_FAILURE() << what << " value " << i << ": host " << host[i] << " device " << device[i];
  EXPECT_EQ(bad, 0u) << what;
}

// A comparison's lanes as bits, every mask of eight lanes, on both of
// rf_lane_bits8's paths: the OR tree any device compiles, and clang's
// sign-bit instruction where the kernels compile with clang's builtins
// (PoCL) for a CPU with AVX, which that build must then take.
TEST_F(KernelUnits, LaneBitsOfEveryMaskOfEightLanes) {
  std::vector<uint32_t> masks(256);
  for (uint32_t m = 0; m < 256; ++m) masks[m] = m;
  std::vector<std::string> builds = {""};
  if (compiles_with_clang_builtins(testing::test_device().info())) builds.push_back("-DRF_CLANG_BUILTINS");
  cl::CommandQueue& q = testing::test_device().queue();
  for (const std::string& defines : builds) {
    const cl::Program program =
        defines.empty() ? *program_
                        : testing::test_device().build(unit_test_program_source(), KernelPrecision::exact, defines);
    cl::Kernel k(program, "ut_lane_bits8");
    const cl::Buffer lanes = in(masks), bits = out(masks.size());
    k.setArg(0, lanes);
    k.setArg(1, bits);
    q.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(masks.size()));
    std::vector<uint32_t> got(masks.size());
    q.enqueueReadBuffer(bits, CL_TRUE, 0, got.size() * sizeof(uint32_t), got.data());
    for (uint32_t m = 0; m < 256; ++m) EXPECT_EQ(got[m], m) << "mask " << m << " built with '" << defines << "'";
    cl::Kernel probe(program, "ut_lane_bits_path");
    const cl::Buffer path = out(1);
    probe.setArg(0, path);
    q.enqueueNDRangeKernel(probe, cl::NullRange, cl::NDRange(1));
    uint32_t sign_bits = 2;
    q.enqueueReadBuffer(path, CL_TRUE, 0, sizeof sign_bits, &sign_bits);
    const bool avx = host_has_avx();
    EXPECT_EQ(sign_bits, defines.empty() ? 0u : (avx ? 1u : 0u))
        << "the path rf_lane_bits8 took, built with '" << defines << "' (1: the sign-bit instruction)";
  }
  if (builds.size() == 1) std::printf("(the sign-bit path needs PoCL; this device ran the OR tree only)\n");
}

// rf_lanes_any on every path it has (eight and sixteen lanes, with clang's
// builtins where the device is PoCL's, which on AVX and AVX-512 hosts test
// the sign bits in one instruction, and without): any lane whose sign bit
// is set, whatever its other bits. Eight lanes: every pattern of sign bits;
// sixteen: each lane alone and random patterns. The low bits are random, so
// a path that tested a lane's value other than by its sign fails.
TEST_F(KernelUnits, LanesAnyOnEveryPath) {
  Rng rng(11);
  cl::CommandQueue& q = testing::test_device().queue();
  const bool builtins = compiles_with_clang_builtins(testing::test_device().info());
  const HostIsa isa = host_isa();
  const bool avx = isa.avx, avx512dq = isa.avx512dq;
  for (int lanes : {8, 16}) {
    const size_t cases = 256 + 16 + 256;
    std::vector<int32_t> values(cases * lanes);
    std::vector<uint32_t> expected(cases);
    for (size_t c = 0; c < cases; ++c) {
      uint32_t signs;
      if (c < 256)
        signs = lanes == 8 ? static_cast<uint32_t>(c) : static_cast<uint32_t>(c) << (c % 2 ? 8 : 0);
      else if (c < 256 + 16)
        signs = 1u << (c - 256);
      else
        signs = static_cast<uint32_t>(rng.next()) & ((1u << lanes) - 1u) & (rng.below(2) ? 0xFFFFFFFFu : 0x11u);
      signs &= (1u << lanes) - 1u;
      for (int l = 0; l < lanes; ++l) {
        const uint32_t low = static_cast<uint32_t>(rng.next()) & 0x7FFFFFFFu;
        const uint32_t bits = ((signs >> l) & 1u) ? 0x80000000u | low : low;
        std::memcpy(&values[c * lanes + l], &bits, sizeof bits);
      }
      expected[c] = signs != 0;
    }
    std::vector<std::string> builds = {"-DRF_LANES=" + std::to_string(lanes)};
    if (builtins) builds.push_back(builds[0] + " -DRF_CLANG_BUILTINS");
    for (const std::string& defines : builds) {
      const cl::Program program =
          testing::test_device().build(unit_test_program_source(), KernelPrecision::exact, defines);
      cl::Kernel k(program, "ut_lanes_any");
      const cl::Buffer input = in(values), answers = out(cases);
      k.setArg(0, input);
      k.setArg(1, answers);
      q.enqueueNDRangeKernel(k, cl::NullRange, cl::NDRange(cases));
      std::vector<uint32_t> got(cases);
      q.enqueueReadBuffer(answers, CL_TRUE, 0, got.size() * sizeof(uint32_t), got.data());
      for (size_t c = 0; c < cases; ++c)
        ASSERT_EQ(got[c], expected[c]) << "case " << c << ", lane values from " << values[c * lanes] << ", built with '"
                                       << defines << "'";
      cl::Kernel probe(program, "ut_lanes_any_path");
      const cl::Buffer path = out(2);
      probe.setArg(0, path);
      q.enqueueNDRangeKernel(probe, cl::NullRange, cl::NDRange(1));
      uint32_t taken[2] = {9, 0};
      q.enqueueReadBuffer(path, CL_TRUE, 0, sizeof taken, taken);
      const bool with_builtins = defines.find("RF_CLANG_BUILTINS") != std::string::npos;
      EXPECT_EQ(taken[1], static_cast<uint32_t>(lanes)) << "built with '" << defines << "'";
      const bool one_instruction = lanes == 8 ? avx : avx512dq;
      EXPECT_EQ(taken[0], !with_builtins ? 0u : (one_instruction ? 2u : 1u))
          << "the path rf_lanes_any took, built with '" << defines
          << "' (2: the sign bits tested in one instruction, 1: clang's reduction, 0: the OR tree)";
    }
  }
  if (!builtins) std::printf("(the builtin paths need PoCL; this device ran the OR tree only)\n");
}

TEST_F(KernelUnits, RayInit) {
  Rng rng(1);
  const size_t n = 4096;
  const std::vector<float> r = rays(rng, n);
  std::vector<float> host(15 * n);
  for (size_t i = 0; i < n; ++i) {
    rf_ray ray;
    rf_ray_init(&ray, r[6 * i], r[6 * i + 1], r[6 * i + 2], r[6 * i + 3], r[6 * i + 4], r[6 * i + 5]);
    float* o = &host[15 * i];
    for (int k = 0; k < 3; ++k) o[k] = ray.invd[k];
    o[3] = ray.sx;
    o[4] = ray.sy;
    o[5] = ray.sz;
    o[6] = static_cast<float>(ray.kx);
    o[7] = static_cast<float>(ray.ky);
    o[8] = static_cast<float>(ray.kz);
    for (int k = 0; k < 3; ++k) {
      o[9 + k] = ray.o[k];
      o[12 + k] = ray.d[k];
    }
  }
  expect_bits_equal(host, run("ut_ray_init", {in(r), out(15 * n)}, n, 15 * n), "rf_ray_init");
}

TEST_F(KernelUnits, RayBox) {
  Rng rng(2);
  const size_t n = 8192;
  const std::vector<float> r = rays(rng, n);
  std::vector<rf_node> boxes(n);
  std::vector<float> tmax(n), host(n);
  size_t hits = 0;
  for (size_t i = 0; i < n; ++i) {
    for (int k = 0; k < 3; ++k) {
      const float a = rng.uniformf(-3, 3), b = rng.uniformf(-3, 3);
      boxes[i].bmin[k] = std::min(a, b);
      boxes[i].bmax[k] = (i % 16 == 0) ? std::min(a, b) : std::max(a, b);  // some flat boxes
    }
    tmax[i] = (i % 3 == 0) ? INFINITY : rng.uniformf(-1, 5);
    rf_ray ray;
    rf_ray_init(&ray, r[6 * i], r[6 * i + 1], r[6 * i + 2], r[6 * i + 3], r[6 * i + 4], r[6 * i + 5]);
    host[i] = rf_intersect_box(&boxes[i], &ray, tmax[i]);
    hits += host[i] != RF_FAR;
  }
  EXPECT_GT(hits, n / 10);  // both outcomes are exercised
  EXPECT_LT(hits, n - n / 10);
  expect_bits_equal(host, run("ut_ray_box", {in(boxes), in(r), in(tmax), out(n)}, n, n), "rf_intersect_box");
}

TEST_F(KernelUnits, RayTriangle) {
  Rng rng(3);
  const size_t n = 8192;
  std::vector<float> r = rays(rng, n);
  std::vector<rf_tri> tris(n);
  std::vector<float> host(4 * n);
  size_t hits = 0;
  for (size_t i = 0; i < n; ++i) {
    rf_tri& t = tris[i];
    for (int k = 0; k < 3; ++k) {
      t.v0[k] = rng.uniformf(-1, 1);
      t.v1[k] = rng.uniformf(-1, 1);
      t.v2[k] = rng.uniformf(-1, 1);
    }
    if (i % 10 == 0) std::memcpy(t.v2, t.v1, sizeof t.v1);  // zero area
    if (i % 10 == 1) {                                      // aim at a vertex exactly
      for (int k = 0; k < 3; ++k) r[6 * i + 3 + k] = t.v0[k] - r[6 * i + k];
    }
    if (i % 10 == 2) {  // aim through the middle of edge v0-v1
      for (int k = 0; k < 3; ++k) r[6 * i + 3 + k] = 0.5f * (t.v0[k] + t.v1[k]) - r[6 * i + k];
    }
    rf_tri_set_normal(&t);
    rf_ray ray;
    rf_ray_init(&ray, r[6 * i], r[6 * i + 1], r[6 * i + 2], r[6 * i + 3], r[6 * i + 4], r[6 * i + 5]);
    float tt = 0, u = 0, v = 0;
    const int hit = rf_intersect_triangle(&t, &ray, &tt, &u, &v);
    host[4 * i] = static_cast<float>(hit);
    host[4 * i + 1] = hit ? tt : 0.0f;
    host[4 * i + 2] = hit ? u : 0.0f;
    host[4 * i + 3] = hit ? v : 0.0f;
    hits += hit;
    if (i % 10 == 0) {
      EXPECT_EQ(hit, 0) << "zero-area triangle hit";
    }
  }
  EXPECT_GT(hits, n / 10);
  expect_bits_equal(host, run("ut_ray_triangle", {in(tris), in(r), out(4 * n)}, n, 4 * n), "rf_intersect_triangle");
}

TEST_F(KernelUnits, Transform) {
  Rng rng(4);
  const size_t n = 4096;
  std::vector<float> xf(12 * n), dir(3 * n), host(6 * n);
  for (float& f : xf) f = rng.uniformf(-100, 100);
  for (float& f : dir) f = rng.uniformf(-1, 1);
  for (size_t i = 0; i < n; ++i) {
    rf_ray r;
    rf_ray_to_object(&r, &xf[12 * i], dir[3 * i], dir[3 * i + 1], dir[3 * i + 2]);
    for (int k = 0; k < 3; ++k) {
      host[6 * i + k] = r.o[k];
      host[6 * i + 3 + k] = r.d[k];
    }
  }
  expect_bits_equal(host, run("ut_transform", {in(xf), in(dir), out(6 * n)}, n, 6 * n), "rf_ray_to_object");
}

TEST_F(KernelUnits, GeometricNormal) {
  Rng rng(5);
  const size_t n = 4096;
  std::vector<rf_tri> tris(n);
  std::vector<rf_normal_xform> xf(n);
  std::vector<float> host(3 * n);
  for (size_t i = 0; i < n; ++i) {
    const float scale = (i % 4 == 0) ? 1e15f : 1.0f;  // would overflow without the rescale
    for (int k = 0; k < 3; ++k) {
      tris[i].v0[k] = scale * rng.uniformf(-1, 1);
      tris[i].v1[k] = scale * rng.uniformf(-1, 1);
      tris[i].v2[k] = scale * rng.uniformf(-1, 1);
    }
    rf_tri_set_normal(&tris[i]);
    for (float& f : xf[i].m) f = rng.uniformf(-2, 2);
    rf_geometric_normal(&tris[i], &xf[i], &host[3 * i]);
    if (i % 4 == 0) {
      EXPECT_TRUE(std::isfinite(host[3 * i])) << "large triangle normal overflowed";
    }
  }
  expect_bits_equal(host, run("ut_normal", {in(tris), in(xf), out(3 * n)}, n, 3 * n), "rf_geometric_normal");
}

// Tiles for the tile kernel's pieces: per case a 3x4 tree_from_trace and
// RF_TILE_RAYS camera-space directions (dx, dy; dz = -1). Even cases are
// coherent 16x16 blocks of primary rays (one axis permutation in the tile, the
// uniform path); odd cases scramble the lanes over a wide cone with zero and
// tied components (per-lane permutations).
struct TileCases {
  std::vector<float> xf, dirs;
  size_t n = 0;
  TileCases(Rng& rng, size_t cases) : xf(12 * cases), dirs(2 * RF_TILE_RAYS * cases), n(cases) {
    for (size_t i = 0; i < cases; ++i) {
      float* m = &xf[12 * i];
      for (int k = 0; k < 12; ++k) m[k] = rng.uniformf(-2, 2);
      if (i % 3 == 0) {  // axis-aligned, mirrored, non-uniformly scaled
        for (int k = 0; k < 12; ++k) m[k] = (k % 5 == 0) ? rng.uniformf(0.5f, 3) * (k == 5 ? -1.0f : 1.0f) : 0.0f;
        m[3] = rng.uniformf(-5, 5);
        m[7] = rng.uniformf(-5, 5);
        m[11] = rng.uniformf(-5, 5);
      }
      const float s = rng.uniformf(0.0005f, 0.01f);
      const int x0 = rng.below(200) - 100, y0 = rng.below(200) - 100;
      for (int l = 0; l < RF_TILE_RAYS; ++l) {
        float* d = &dirs[2 * (RF_TILE_RAYS * i + l)];
        if (i % 2 == 0) {
          d[0] = s * static_cast<float>(2 * (x0 + l % 16) + 1);
          d[1] = s * static_cast<float>(2 * (y0 + l / 16) + 1);
        } else {
          d[0] = rng.uniformf(-3, 3);
          d[1] = rng.uniformf(-3, 3);
          if (l % 7 == 0) d[0] = 0.0f;
          if (l % 11 == 0) d[1] = -1.0f;  // |dy| = |dz|
          if (l % 13 == 0) d[0] = d[1];
        }
      }
    }
  }
  rf_ray lane_ray(size_t i, int l) const {
    rf_ray r;
    const float* d = &dirs[2 * (RF_TILE_RAYS * i + l)];
    rf_ray_to_object(&r, &xf[12 * i], d[0], d[1], -1.0f);
    return r;
  }
};

TEST_F(KernelUnits, TileObjectRaysEqualScalarSetUp) {
  Rng rng(6);
  const TileCases c(rng, 64);
  const size_t per = 9 * RF_TILE_RAYS + 7;
  std::vector<float> host(per * c.n);
  size_t uniform = 0;
  for (size_t i = 0; i < c.n; ++i) {
    float* o = &host[per * i];
    float lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    bool same = true;
    const rf_ray r0 = c.lane_ray(i, 0);
    for (int l = 0; l < RF_TILE_RAYS; ++l) {
      const rf_ray r = c.lane_ray(i, l);
      for (int k = 0; k < 3; ++k) {
        o[9 * l + k] = r.invd[k];
        lo[k] = std::min(lo[k], r.invd[k]);
        hi[k] = std::max(hi[k], r.invd[k]);
      }
      o[9 * l + 3] = r.sx;
      o[9 * l + 4] = r.sy;
      o[9 * l + 5] = r.sz;
      o[9 * l + 6] = static_cast<float>(r.kx);
      o[9 * l + 7] = static_cast<float>(r.ky);
      o[9 * l + 8] = static_cast<float>(r.kz);
      same = same && r.kx == r0.kx && r.ky == r0.ky && r.kz == r0.kz;
    }
    for (int k = 0; k < 3; ++k) {
      o[9 * RF_TILE_RAYS + k] = lo[k];
      o[9 * RF_TILE_RAYS + 3 + k] = hi[k];
    }
    o[9 * RF_TILE_RAYS + 6] = same ? 1.0f : 0.0f;
    uniform += same;
  }
  EXPECT_GT(uniform, 0u);  // both paths are exercised
  EXPECT_LT(uniform, c.n);
  expect_bits_equal(host, run("ut_tile_to_object", {in(c.xf), in(c.dirs), out(per * c.n)}, c.n, per * c.n),
                    "rf_tile_to_object");
}

TEST_F(KernelUnits, TileLaneBoxEqualsScalarBoxTest) {
  Rng rng(7);
  const TileCases c(rng, 64);
  std::vector<rf_node> boxes(c.n);
  std::vector<float> tmax(RF_TILE_RAYS * c.n), host(RF_TILE_RAYS * c.n);
  size_t pass = 0;
  for (size_t i = 0; i < c.n; ++i) {
    for (int k = 0; k < 3; ++k) {
      const float a = rng.uniformf(-8, 8), b = rng.uniformf(-8, 8);
      boxes[i].bmin[k] = std::min(a, b);
      boxes[i].bmax[k] = (i % 8 == 0 && k == 1) ? std::min(a, b) : std::max(a, b);  // some flat boxes
    }
    for (int l = 0; l < RF_TILE_RAYS; ++l) {
      const size_t q = RF_TILE_RAYS * i + l;
      tmax[q] = (l % 3 == 0) ? RF_FAR : rng.uniformf(-1, 20);
      const rf_ray r = c.lane_ray(i, l);
      host[q] = rf_intersect_box(&boxes[i], &r, tmax[q]);
      pass += host[q] != RF_FAR;
    }
  }
  EXPECT_GT(pass, host.size() / 20);
  EXPECT_LT(pass, host.size() - host.size() / 20);
  expect_bits_equal(host,
                    run("ut_tile_box", {in(boxes), in(c.xf), in(c.dirs), in(tmax), out(host.size())}, c.n, host.size()),
                    "rf_lanes_box and rf_lanes_box_entry");
}

TEST_F(KernelUnits, TileTriangleEqualsScalarTriangleTest) {
  Rng rng(8);
  TileCases c(rng, 64);
  std::vector<rf_tri> tris(c.n);
  std::vector<float> host(4 * RF_TILE_RAYS * c.n);
  size_t hits = 0;
  for (size_t i = 0; i < c.n; ++i) {
    rf_tri& t = tris[i];
    // A triangle in front of the tile's rays, large enough to catch some.
    const rf_ray centre = c.lane_ray(i, RF_TILE_RAYS / 2 + 8);
    const float dist = rng.uniformf(1, 6);
    for (int k = 0; k < 3; ++k) {
      const float p = centre.o[k] + dist * centre.d[k];
      t.v0[k] = p + rng.uniformf(-3, 3);
      t.v1[k] = p + rng.uniformf(-3, 3);
      t.v2[k] = p + rng.uniformf(-3, 3);
    }
    if (i % 16 == 5) std::memcpy(t.v2, t.v1, sizeof t.v1);  // zero area
    t.prim = 0;
    rf_tri_set_normal(&t);
    for (int l = 0; l < RF_TILE_RAYS; ++l) {
      const rf_ray r = c.lane_ray(i, l);
      float tt = 0, u = 0, v = 0;
      const int hit = rf_intersect_triangle(&t, &r, &tt, &u, &v) && tt > 0.0f && tt < RF_FAR;
      float* o = &host[4 * (RF_TILE_RAYS * i + l)];
      o[0] = static_cast<float>(hit);
      o[1] = hit ? tt : 0.0f;
      o[2] = hit ? u : 0.0f;
      o[3] = hit ? v : 0.0f;
      hits += hit;
    }
  }
  EXPECT_GT(hits, host.size() / 4 / 20);
  expect_bits_equal(host, run("ut_tile_triangle", {in(tris), in(c.xf), in(c.dirs), out(host.size())}, c.n, host.size()),
                    "rf_tile_triangle");
}

}  // namespace
}  // namespace rayfold::core
