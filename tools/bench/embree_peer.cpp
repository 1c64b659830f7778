#include "bench/embree_peer.h"

#include "bench/peak_memory.h"
#include "util/errors.h"
#include "util/parallel.h"
#include "util/timer.h"

#ifdef RAYFOLD_HAVE_EMBREE
#include <embree3/rtcore.h>

#include <algorithm>
#include <chrono>
#include <cmath>

namespace rayfold::core {

struct EmbreePeer::Impl {
  const Scene& scene;
  const SceneData& data;
  unsigned threads;
  RTCDevice device = nullptr;
  RTCScene top = nullptr;
  RTCScene flat = nullptr;       // every instance's triangles in world space, one geometry per instance
  RTCScene flat_high = nullptr;  // the same, RTC_BUILD_QUALITY_HIGH
  double flat_build_ms = 0.0, flat_high_build_ms = 0.0;
  size_t flat_peak_bytes = 0, flat_high_peak_bytes = 0;
  std::vector<RTCScene> meshes;
  std::vector<RTCGeometry> instances;  // per scene instance, null when hidden
  Camera camera;
  float eye[3] = {0, 0, 0};    // world space, for the flat scene
  float world_dir[3][3] = {};  // world_from_camera's linear part, row-major
  // Per scene instance, what turns the flat scene's Ng into rayfold's
  // orientation: 1, or -1 under a mirroring world_from_object.
  std::vector<float> normal_sign;

  Impl(const Scene& s, const SceneData& d, unsigned t, const std::string& isa, bool flat_only)
      : scene(s), data(d), threads(t) {
    std::string config = "threads=" + std::to_string(threads);
    if (!isa.empty()) config += ",isa=" + isa;
    device = rtcNewDevice(config.c_str());
    if (!device) throw RuntimeFailure("Embree: rtcNewDevice(\"" + config + "\") failed");
    for (const Instance& inst : scene.instances)
      normal_sign.push_back(linear_determinant(inst.world_from_object) < 0.0 ? -1.0f : 1.0f);
    if (flat_only) {
      flat = make_flat(RTC_BUILD_QUALITY_MEDIUM, &flat_build_ms, &flat_peak_bytes);
      return;
    }
    for (const Mesh& m : scene.meshes) {
      RTCScene ms = rtcNewScene(device);
      RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
      auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                             3 * sizeof(float), m.positions.size()));
      auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                3 * sizeof(unsigned), m.triangle_count()));
      for (size_t i = 0; i < m.positions.size(); ++i)
        for (int k = 0; k < 3; ++k) vb[3 * i + k] = m.positions[i][k];
      std::copy(m.indices.begin(), m.indices.end(), ib);
      rtcSetGeometryBuildQuality(g, RTC_BUILD_QUALITY_HIGH);
      rtcCommitGeometry(g);
      rtcAttachGeometry(ms, g);
      rtcReleaseGeometry(g);
      rtcCommitScene(ms);
      meshes.push_back(ms);
    }
    top = rtcNewScene(device);
    instances.assign(scene.instances.size(), nullptr);
    for (size_t i = 0; i < scene.instances.size(); ++i) {
      if (!data.renderable[i]) continue;
      RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_INSTANCE);
      rtcSetGeometryInstancedScene(g, meshes[scene.instances[i].mesh]);
      rtcAttachGeometryByID(top, g, static_cast<unsigned>(i));
      instances[i] = g;
    }
    flat = make_flat(RTC_BUILD_QUALITY_MEDIUM, &flat_build_ms, &flat_peak_bytes);
    flat_high = make_flat(RTC_BUILD_QUALITY_HIGH, &flat_high_build_ms, &flat_high_peak_bytes);
  }

  // As a user with a static scene builds it: instances flattened into one
  // single-level world-space tree, built once at this quality (MEDIUM is
  // Embree's default). build_ms and peak_bytes: rtcCommitScene, the build
  // alone (the vertex and index buffers it reads exist before).
  RTCScene make_flat(RTCBuildQuality quality, double* build_ms, size_t* peak_bytes) {
    RTCScene s = rtcNewScene(device);
    for (size_t i = 0; i < scene.instances.size(); ++i) {
      if (!data.renderable[i]) continue;
      const Mesh& m = scene.meshes[scene.instances[i].mesh];
      const Xform& w = scene.instances[i].world_from_object;
      RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
      auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                             3 * sizeof(float), m.positions.size()));
      auto* ib = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                3 * sizeof(unsigned), m.triangle_count()));
      for (size_t v = 0; v < m.positions.size(); ++v) {
        const glm::dvec4 p = w * glm::dvec4(glm::dvec3(m.positions[v]), 1.0);
        for (int k = 0; k < 3; ++k) vb[3 * v + k] = static_cast<float>(p[k]);
      }
      std::copy(m.indices.begin(), m.indices.end(), ib);
      rtcSetGeometryBuildQuality(g, quality);
      rtcCommitGeometry(g);
      rtcAttachGeometryByID(s, g, static_cast<unsigned>(i));
      rtcReleaseGeometry(g);
    }
    rtcSetSceneBuildQuality(s, quality);
    const PeakMemory memory;
    const auto t0 = Clock::now();
    rtcCommitScene(s);
    *build_ms = ms_since(t0);
    *peak_bytes = memory.peak_bytes();
    return s;
  }

  ~Impl() {
    for (RTCGeometry g : instances)
      if (g) rtcReleaseGeometry(g);
    if (top) rtcReleaseScene(top);
    if (flat) rtcReleaseScene(flat);
    if (flat_high) rtcReleaseScene(flat_high);
    for (RTCScene s : meshes) rtcReleaseScene(s);
    if (device) rtcReleaseDevice(device);
  }

  void set_camera(const Camera& cam) {
    camera = cam;
    for (size_t i = 0; i < instances.size(); ++i) {
      if (!instances[i]) continue;
      const Xform m = cam.camera_from_world * scene.instances[i].world_from_object;
      float xfm[12];
      for (int c = 0; c < 4; ++c)
        for (int r = 0; r < 3; ++r) xfm[3 * c + r] = static_cast<float>(m[c][r]);
      rtcSetGeometryTransform(instances[i], 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm);
      rtcCommitGeometry(instances[i]);
    }
    if (top) rtcCommitScene(top);
    for (int r = 0; r < 3; ++r) {
      eye[r] = static_cast<float>(cam.world_from_camera[3][r]);
      for (int c = 0; c < 3; ++c) world_dir[r][c] = static_cast<float>(cam.world_from_camera[c][r]);
    }
  }

  // The ray of pixel (x, y) in the traced scene's space: camera space with
  // the eye at the origin for the instanced scene, world space for the flat
  // one (the same direction turned, not renormalised, so t keeps its meaning).
  void ray(int x, int y, bool flat_scene, float o[3], float d[3], float cam_d[3]) const {
    direction(x, y, cam_d);
    for (int r = 0; r < 3; ++r) {
      o[r] = flat_scene ? eye[r] : 0.0f;
      d[r] =
          flat_scene ? world_dir[r][0] * cam_d[0] + world_dir[r][1] * cam_d[1] + world_dir[r][2] * cam_d[2] : cam_d[r];
    }
  }

  // rayfold's ray for pixel (x, y), bit for bit (kernels/rf_trace.h).
  void direction(int x, int y, float d[3]) const {
    const rf_camera& c = camera.params;
    d[0] = c.scale_x * (static_cast<float>(2 * x + c.kx0) + c.frac_x);
    d[1] = c.scale_y * (static_cast<float>(c.ky0 - 2 * y) + c.frac_y);
    d[2] = -1.0f;
  }

  // The G-buffer rayfold writes for a hit, so that both tracers' frames do
  // the same work: depth, the world-space unit geometric normal, the
  // barycentrics and the ids. Embree's Ng is unnormalised, in world space in
  // the flat scene (where a mirroring transform has turned the winding that
  // rayfold's normal keeps) and in object space in the instanced one. inst:
  // the instance for the instanced scene, the geometry (= instance) for the
  // flat one; d: the camera-space direction for a frame (z is the distance
  // along it normalised), null for a ray query (z = t).
  void store(rf_pixel_hit& h, float t, unsigned inst, unsigned prim, const float* d, bool flat_scene, float ngx,
             float ngy, float ngz, float u, float v) const {
    if (inst == RTC_INVALID_GEOMETRY_ID) {
      h = rf_pixel_hit{};
      h.z = INFINITY;
      h.instance = h.primitive = RF_INVALID;
      return;
    }
    h.z = d ? t * std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) : t;
    float n[3] = {ngx, ngy, ngz};
    if (flat_scene) {
      const float s = normal_sign[inst];
      for (float& c : n) c *= s;
    } else {
      const float* m = data.normal_xforms[inst].m;
      for (int r = 0; r < 3; ++r) n[r] = m[3 * r] * ngx + m[3 * r + 1] * ngy + m[3 * r + 2] * ngz;
    }
    const float len = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    const float k = len > 0.0f ? 1.0f / len : 0.0f;
    h.nx = n[0] * k;
    h.ny = n[1] * k;
    h.nz = n[2] * k;
    h.u = u;
    h.v = v;
    h.instance = inst;
    h.primitive = prim;
  }

  RTCScene traced(EmbreeScene which) const {
    RTCScene s = which == EmbreeScene::instanced ? top : which == EmbreeScene::flat ? flat : flat_high;
    RF_CHECK(s != nullptr, "this Embree peer was built with its flat default-quality scene only");
    return s;
  }

  template <class Tile>
  double run(Tile tile, int tiles) {
    const auto t0 = Clock::now();
    parallel_for(static_cast<size_t>(tiles), threads, 1, [&](size_t i, size_t) { tile(static_cast<int>(i)); });
    return ms_since(t0);
  }
};

namespace {

// One ray from o along d, t in [0, inf), as every call here traces it.
RTCRayHit ray1(const float o[3], const float d[3]) {
  RTCRayHit rh{};
  rh.ray.org_x = o[0];
  rh.ray.org_y = o[1];
  rh.ray.org_z = o[2];
  rh.ray.dir_x = d[0];
  rh.ray.dir_y = d[1];
  rh.ray.dir_z = d[2];
  rh.ray.tnear = 0.0f;
  rh.ray.tfar = INFINITY;
  rh.ray.mask = 0xFFFFFFFFu;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
  return rh;
}

// The same as lane l of a packet.
void set_lane(RTCRayHit16& rh, int l, const float o[3], const float d[3]) {
  rh.ray.org_x[l] = o[0];
  rh.ray.org_y[l] = o[1];
  rh.ray.org_z[l] = o[2];
  rh.ray.dir_x[l] = d[0];
  rh.ray.dir_y[l] = d[1];
  rh.ray.dir_z[l] = d[2];
  rh.ray.tnear[l] = 0.0f;
  rh.ray.tfar[l] = INFINITY;
  rh.ray.time[l] = 0.0f;
  rh.ray.mask[l] = 0xFFFFFFFFu;
  rh.ray.flags[l] = 0;
  rh.hit.geomID[l] = RTC_INVALID_GEOMETRY_ID;
  rh.hit.instID[0][l] = RTC_INVALID_GEOMETRY_ID;
}

}  // namespace

bool EmbreePeer::available() { return true; }

EmbreePeer::EmbreePeer(const Scene& scene, const SceneData& data, unsigned threads, const std::string& isa,
                       bool flat_only)
    : impl_(std::make_unique<Impl>(scene, data, threads, isa, flat_only)) {}
EmbreePeer::~EmbreePeer() = default;

std::string EmbreePeer::isa(const std::string& host_isa) const {
  // Embree traces with the widest ISA both its build and its device allow;
  // the native packet width tells that ISA apart but for AVX from AVX2.
  RTCDevice d = impl_->device;
  if (rtcGetDeviceProperty(d, RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED)) return "AVX-512";
  if (rtcGetDeviceProperty(d, RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED)) return host_isa == "AVX" ? "AVX" : "AVX2";
  return "SSE";
}

void EmbreePeer::set_camera(const Camera& camera) { impl_->set_camera(camera); }
size_t EmbreePeer::build_peak_bytes(EmbreeScene which) const {
  return which == EmbreeScene::flat ? impl_->flat_peak_bytes
                                    : which == EmbreeScene::flat_high ? impl_->flat_high_peak_bytes : 0;
}

double EmbreePeer::build_ms(EmbreeScene which) const {
  return which == EmbreeScene::flat ? impl_->flat_build_ms : which == EmbreeScene::flat_high ? impl_->flat_high_build_ms : 0.0;
}

double EmbreePeer::rebuild_ms(EmbreeScene which) {
  RF_CHECK(which != EmbreeScene::instanced, "only the flat scenes are rebuilt");
  double ms = 0.0;
  size_t peak = 0;
  rtcReleaseScene(impl_->make_flat(which == EmbreeScene::flat ? RTC_BUILD_QUALITY_MEDIUM : RTC_BUILD_QUALITY_HIGH, &ms,
                                   &peak));
  return ms;
}

double EmbreePeer::trace1(std::vector<rf_pixel_hit>& hits, EmbreeScene which) {
  Impl& m = *impl_;
  const bool flat = which != EmbreeScene::instanced;
  RTCScene scene = m.traced(which);
  const int w = m.camera.width, h = m.camera.height;
  hits.resize(static_cast<size_t>(w) * h);
  return m.run(
      [&](int y) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        for (int x = 0; x < w; ++x) {
          float o[3], d[3], cam_d[3];
          m.ray(x, y, flat, o, d, cam_d);
          RTCRayHit rh = ray1(o, d);
          rtcIntersect1(scene, &ctx, &rh);
          m.store(hits[static_cast<size_t>(y) * w + x], rh.ray.tfar, flat ? rh.hit.geomID : rh.hit.instID[0],
                  rh.hit.primID, cam_d, flat, rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z, rh.hit.u, rh.hit.v);
        }
      },
      h);
}

double EmbreePeer::trace16(std::vector<rf_pixel_hit>& hits, EmbreeScene which) {
  Impl& m = *impl_;
  const bool flat = which != EmbreeScene::instanced;
  RTCScene scene = m.traced(which);
  const int w = m.camera.width, h = m.camera.height;
  hits.resize(static_cast<size_t>(w) * h);
  const int tx = (w + 3) / 4, ty = (h + 3) / 4;
  return m.run(
      [&](int tile) {
        const int x0 = 4 * (tile % tx), y0 = 4 * (tile / tx);
        alignas(64) RTCRayHit16 rh;
        alignas(64) int valid[16];
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
        float dirs[16][3];
        for (int i = 0; i < 16; ++i) {
          const int x = x0 + i % 4, y = y0 + i / 4;
          valid[i] = (x < w && y < h) ? -1 : 0;
          float o[3], d[3];
          m.ray(std::min(x, w - 1), std::min(y, h - 1), flat, o, d, dirs[i]);
          set_lane(rh, i, o, d);
        }
        rtcIntersect16(valid, scene, &ctx, &rh);
        for (int i = 0; i < 16; ++i)
          if (valid[i])
            m.store(hits[static_cast<size_t>(y0 + i / 4) * w + x0 + i % 4], rh.ray.tfar[i],
                    flat ? rh.hit.geomID[i] : rh.hit.instID[0][i], rh.hit.primID[i], dirs[i], flat, rh.hit.Ng_x[i],
                    rh.hit.Ng_y[i], rh.hit.Ng_z[i], rh.hit.u[i], rh.hit.v[i]);
      },
      tx * ty);
}

double EmbreePeer::intersect1(const float* o, const float* d, size_t n, std::vector<rf_pixel_hit>& hits,
                              EmbreeScene which) {
  RF_CHECK(which != EmbreeScene::instanced, "ray queries run on a flat scene");
  Impl& m = *impl_;
  RTCScene scene = m.traced(which);
  hits.resize(n);
  constexpr size_t kChunk = 4096;
  const auto t0 = Clock::now();
  parallel_for(n, m.threads, kChunk, [&](size_t begin, size_t end) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    for (size_t i = begin; i < end; ++i) {
      RTCRayHit rh = ray1(o + 3 * i, d + 3 * i);
      rtcIntersect1(scene, &ctx, &rh);
      m.store(hits[i], rh.ray.tfar, rh.hit.geomID, rh.hit.primID, nullptr, true, rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z,
              rh.hit.u, rh.hit.v);
    }
  });
  return ms_since(t0);
}

double EmbreePeer::intersect16(const float* o, const float* d, size_t n, size_t row_length,
                               std::vector<rf_pixel_hit>& hits, EmbreeScene which) {
  RF_CHECK(which != EmbreeScene::instanced, "ray queries run on a flat scene");
  Impl& m = *impl_;
  RTCScene scene = m.traced(which);
  hits.resize(n);
  const bool image = row_length > 0 && n % row_length == 0;
  const size_t rows = image ? n / row_length : 0;
  const size_t bx = image ? (row_length + 3) / 4 : 0;
  const size_t packets = image ? bx * ((rows + 3) / 4) : (n + 15) / 16;
  const auto t0 = Clock::now();
  parallel_for(packets, m.threads, 64, [&](size_t begin, size_t end) {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = image ? RTC_INTERSECT_CONTEXT_FLAG_COHERENT : RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
    alignas(64) RTCRayHit16 rh;
    alignas(64) int valid[16];
    size_t index[16];
    for (size_t p = begin; p < end; ++p) {
      for (int l = 0; l < 16; ++l) {
        size_t i;
        bool ok;
        if (image) {
          const size_t x = 4 * (p % bx) + l % 4, y = 4 * (p / bx) + l / 4;
          ok = x < row_length && y < rows;
          i = ok ? y * row_length + x : 0;
        } else {
          i = 16 * p + l;
          ok = i < n;
          if (!ok) i = 0;
        }
        index[l] = i;
        valid[l] = ok ? -1 : 0;
        set_lane(rh, l, o + 3 * i, d + 3 * i);
      }
      rtcIntersect16(valid, scene, &ctx, &rh);
      for (int l = 0; l < 16; ++l)
        if (valid[l])
          m.store(hits[index[l]], rh.ray.tfar[l], rh.hit.geomID[l], rh.hit.primID[l], nullptr, true, rh.hit.Ng_x[l],
                  rh.hit.Ng_y[l], rh.hit.Ng_z[l], rh.hit.u[l], rh.hit.v[l]);
    }
  });
  return ms_since(t0);
}

}  // namespace rayfold::core

#else  // no Embree

namespace rayfold::core {

struct EmbreePeer::Impl {};
bool EmbreePeer::available() { return false; }
EmbreePeer::EmbreePeer(const Scene&, const SceneData&, unsigned, const std::string&, bool) {
  throw RuntimeFailure("rayfold was built without Embree (install libembree-dev and rebuild)");
}
EmbreePeer::~EmbreePeer() = default;
std::string EmbreePeer::isa(const std::string&) const { return "none"; }
void EmbreePeer::set_camera(const Camera&) {}
double EmbreePeer::build_ms(EmbreeScene) const { return 0.0; }
double EmbreePeer::rebuild_ms(EmbreeScene) { return 0.0; }
size_t EmbreePeer::build_peak_bytes(EmbreeScene) const { return 0; }
double EmbreePeer::trace1(std::vector<rf_pixel_hit>&, EmbreeScene) { return 0.0; }
double EmbreePeer::trace16(std::vector<rf_pixel_hit>&, EmbreeScene) { return 0.0; }
double EmbreePeer::intersect1(const float*, const float*, size_t, std::vector<rf_pixel_hit>&, EmbreeScene) {
  return 0.0;
}
double EmbreePeer::intersect16(const float*, const float*, size_t, size_t, std::vector<rf_pixel_hit>&, EmbreeScene) {
  return 0.0;
}

}  // namespace rayfold::core

#endif
