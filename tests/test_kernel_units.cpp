// Single shared functions run on the OpenCL device (rf_unit_tests.cl) must
// give the host compilation's bits exactly, on random and edge-case inputs.
#include <gtest/gtest.h>

#include <cstring>

#include "../host/kernel_sources.h"
#include "../kernels/rf_trace.h"
#include "test_util.h"

namespace rayfold {
namespace {

using testing::Rng;

class KernelUnits : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    program_ = new cl::Program(testing::test_device().build(unit_test_program_source(), KernelPrecision::exact));
  }
  static void TearDownTestSuite() {
    delete program_;
    program_ = nullptr;
  }

  template <class T>
  cl::Buffer in(const std::vector<T>& v) {
    return cl::Buffer(testing::test_device().context(), CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR,
                      v.size() * sizeof(T), const_cast<T*>(v.data()));
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
        case 1: r[6 * i + 4] = -0.0f; r[6 * i + 5] = 0.0f; break;
        case 2: r[6 * i + 3] = 1e-35f; break;
        case 3: r[6 * i + 5] = 1e20f; break;
        case 4: r[6 * i + 3] = r[6 * i + 4]; r[6 * i + 5] = r[6 * i + 4]; break;  // |dx|=|dy|=|dz| tie
        default: break;
      }
    }
    return r;
  }

  static cl::Program* program_;
};

cl::Program* KernelUnits::program_ = nullptr;

void expect_bits_equal(const std::vector<float>& host, const std::vector<float>& device, const char* what) {
  ASSERT_EQ(host.size(), device.size());
  size_t bad = 0;
  for (size_t i = 0; i < host.size(); ++i)
    if (std::memcmp(&host[i], &device[i], 4) != 0 && bad++ < 5)
      ADD_FAILURE() << what << " value " << i << ": host " << host[i] << " device " << device[i];
  EXPECT_EQ(bad, 0u) << what;
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
    if (i % 10 == 1) {                                       // aim at a vertex exactly
      for (int k = 0; k < 3; ++k) r[6 * i + 3 + k] = t.v0[k] - r[6 * i + k];
    }
    if (i % 10 == 2) {  // aim through the middle of edge v0-v1
      for (int k = 0; k < 3; ++k) r[6 * i + 3 + k] = 0.5f * (t.v0[k] + t.v1[k]) - r[6 * i + k];
    }
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
    for (float& f : xf[i].m) f = rng.uniformf(-2, 2);
    rf_geometric_normal(&tris[i], &xf[i], &host[3 * i]);
    if (i % 4 == 0) {
      EXPECT_TRUE(std::isfinite(host[3 * i])) << "large triangle normal overflowed";
    }
  }
  expect_bits_equal(host, run("ut_normal", {in(tris), in(xf), out(3 * n)}, n, 3 * n), "rf_geometric_normal");
}

}  // namespace
}  // namespace rayfold
