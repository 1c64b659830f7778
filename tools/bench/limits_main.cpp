// rayfold-limits: where exactness ends, measured beside Embree, for
// docs/exactness.md. A generated atrium scaled by powers of two and of ten,
// seen from ever farther away with the view narrowed to keep it in frame, and
// a scene mixing sizes 2^166 apart. rayfold is the CPU reference tracer (the
// OpenCL kernels give its bits, tests/test_scale.cpp); Embree traces the same
// float camera rays with rtcIntersect1 over its flat and its instanced scene.
// The power-of-two rows also validate: rayfold must be bit-identical to the
// unscaled render with depths times 2^k (exit 3 when not).
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include "cli/cli_args.h"
#include "bench/embree_peer.h"
#include "reference/double_reference.h"
#include "pipeline/pipeline.h"
#include "fixtures/scene_gen.h"
#include "util/atomic_file.h"
#include "util/errors.h"
#include "util/span.h"

namespace rayfold::core {
namespace {

struct Render {
  HitBuffer rayfold;
  std::vector<rf_pixel_hit> embree_flat, embree_instanced;  // empty: Embree refused the rays
};

// Embree's hits in a child process: Embree asserts (and aborts) on rays it
// considers invalid, such as origins beyond 1.8e18; the table then says so.
std::vector<rf_pixel_hit> embree_hits(const Scene& scene, const SceneData& data, const Camera& camera,
                                      EmbreeScene which) {
  std::vector<rf_pixel_hit> hits(static_cast<size_t>(camera.width) * camera.height);
  int fd[2];
  if (pipe(fd) != 0) throw RuntimeFailure("pipe failed");
  const pid_t pid = fork();
  if (pid < 0) throw RuntimeFailure("fork failed");
  if (pid == 0) {
    close(fd[0]);
    EmbreePeer peer(scene, data, 0);
    peer.set_camera(camera);
    peer.trace1(hits, which);
    const char* p = reinterpret_cast<const char*>(hits.data());
    size_t left = hits.size() * sizeof(rf_pixel_hit);
    while (left > 0) {
      const ssize_t n = write(fd[1], p, left);
      if (n <= 0) _exit(1);
      p += n;
      left -= static_cast<size_t>(n);
    }
    _exit(0);
  }
  close(fd[1]);
  char* p = reinterpret_cast<char*>(hits.data());
  size_t got = 0, want = hits.size() * sizeof(rf_pixel_hit);
  for (ssize_t n; got < want && (n = read(fd[0], p + got, want - got)) > 0;) got += static_cast<size_t>(n);
  close(fd[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (got != want || !WIFEXITED(status) || WEXITSTATUS(status) != 0) hits.clear();
  return hits;
}

Render render_all(const Scene& scene, const Camera& camera) {
  Render r;
  PipelineOptions cpu;
  cpu.backend = Backend::cpu;
  Pipeline renderer(scene, cpu);
  r.rayfold = renderer.render(camera).hits;
  if (EmbreePeer::available()) {
    r.embree_flat = embree_hits(scene, renderer.scene_data(), camera, EmbreeScene::flat);
    r.embree_instanced = embree_hits(scene, renderer.scene_data(), camera, EmbreeScene::instanced);
  }
  return r;
}

size_t hits(ConstSpan<rf_pixel_hit> h) {
  size_t n = 0;
  for (const rf_pixel_hit& p : h) n += p.instance != RF_INVALID;
  return n;
}

// Share of pixels with the same (instance, primitive) as `base`, misses
// included.
double same_triangle(ConstSpan<rf_pixel_hit> base, ConstSpan<rf_pixel_hit> h) {
  if (h.empty()) return 0.0;
  size_t n = 0;
  for (size_t i = 0; i < h.size(); ++i) n += h[i].instance == base[i].instance && h[i].primitive == base[i].primitive;
  return static_cast<double>(n) / h.size();
}

std::string pct(double share) {
  char s[32];
  std::snprintf(s, sizeof s, "%.2f%%", 100.0 * share);
  return s;
}
std::string kept(ConstSpan<rf_pixel_hit> base, ConstSpan<rf_pixel_hit> h) {
  if (h.empty()) return "aborts";
  return pct(hits(base) ? static_cast<double>(hits(h)) / hits(base) : 0.0);
}

Scene scaled(const Scene& scene, double factor) {
  Scene s = scene;
  for (Instance& inst : s.instances) {
    Xform scale(1.0);
    scale[0][0] = scale[1][1] = scale[2][2] = factor;
    inst.world_from_object = scale * inst.world_from_object;
  }
  return s;
}

CameraSpec scaled(CameraSpec spec, double factor) {
  spec.eye *= factor;
  spec.look_at *= factor;
  return spec;
}

bool bit_identical_scaled(ConstSpan<rf_pixel_hit> base, ConstSpan<rf_pixel_hit> h, int k) {
  for (size_t i = 0; i < h.size(); ++i) {
    rf_pixel_hit e = base[i];
    e.z = std::ldexp(e.z, k);
    if (std::memcmp(&e, &h[i], sizeof e) != 0) return false;
  }
  return true;
}

int run(int width, int height, const std::string& md) {
  GenOptions gen;
  gen.objects = 60;
  gen.triangle_budget = 30000;
  const Scene atrium = generate_atrium(gen);
  const CameraSpec view = frame_bounds(atrium.world_bounds(), 50.0);
  const Camera cam0 = make_camera(view, width, height);
  const Render base = render_all(atrium, cam0);
  std::string out;
  char line[512];
  std::snprintf(line, sizeof line,
                "# rayfold-limits: a generated atrium (%zu triangles, about 2^%d across), %dx%d, CPU reference "
                "against Embree %s\n\n",
                atrium.triangle_count(), std::ilogb(glm::length(glm::dvec3(atrium.world_bounds().extent()))), width,
                height, EmbreePeer::available() ? "3 (rtcIntersect1)" : "(not built)");
  out += line;
  out += "## Scaled by 2^k (scene and camera): hits kept, and rayfold bit for bit\n\n";
  out +=
      "| k | rayfold hits | rayfold bits (depth x 2^k) | Embree flat hits | Embree flat same triangle | "
      "Embree instanced hits |\n|---|---|---|---|---|---|\n";
  bool valid = true;
  for (int k : {-140, -120, -100, -80, -60, -40, -20, 20, 40, 60, 80, 100, 120}) {
    std::string rf_bits;
    Render r;
    try {
      r = render_all(scaled(atrium, std::ldexp(1.0, k)), make_camera(scaled(view, std::ldexp(1.0, k)), width, height));
    } catch (const std::exception& e) {
      std::snprintf(line, sizeof line, "| %d | refused: %s | | | | |\n", k, e.what());
      out += line;
      continue;
    }
    const bool exact = bit_identical_scaled(base.rayfold, r.rayfold, k);
    if (k >= -100 && k <= 100) valid = valid && exact;
    std::snprintf(line, sizeof line, "| %d | %s | %s | %s | %s | %s |\n", k, kept(base.rayfold, r.rayfold).c_str(),
                  exact ? "identical" : "differ", kept(base.embree_flat, r.embree_flat).c_str(),
                  r.embree_flat.empty() ? "aborts" : pct(same_triangle(base.embree_flat, r.embree_flat)).c_str(),
                  kept(base.embree_instanced, r.embree_instanced).c_str());
    out += line;
  }

  out += "\n## Scaled by 10^e: hits kept and the same triangle as unscaled\n\n";
  out +=
      "| e | rayfold hits | rayfold same triangle | Embree flat hits | Embree flat same triangle |\n"
      "|---|---|---|---|---|\n";
  for (int e : {-36, -30, -24, -18, -12, -6, 6, 12, 13, 14, 18, 24, 30, 36}) {
    const double f = std::pow(10.0, e);
    Render r;
    try {
      r = render_all(scaled(atrium, f), make_camera(scaled(view, f), width, height));
    } catch (const std::exception& ex) {
      std::snprintf(line, sizeof line, "| %d | refused: %s | | | |\n", e, ex.what());
      out += line;
      continue;
    }
    std::snprintf(line, sizeof line, "| %d | %s | %s | %s | %s |\n", e, kept(base.rayfold, r.rayfold).c_str(),
                  pct(same_triangle(base.rayfold, r.rayfold)).c_str(), kept(base.embree_flat, r.embree_flat).c_str(),
                  r.embree_flat.empty() ? "aborts" : pct(same_triangle(base.embree_flat, r.embree_flat)).c_str());
    out += line;
  }

  out += "\n## Seen from D times its size, the view narrowed to keep it in frame: against the double reference\n\n";
  out +=
      "| D | rayfold same triangle | rayfold hit/miss disagreements | Embree flat same triangle | "
      "Embree flat hit/miss disagreements |\n|---|---|---|---|---|\n";
  for (double d : {1e1, 1e3, 1e5, 1e6, 1e7, 1e8, 1e10, 1e12, 1e15}) {
    const double vfov = 2.0 * std::asin(1.0 / d) * 180.0 / M_PI;
    const Camera cam = make_camera(frame_bounds(atrium.world_bounds(), vfov), width, height);
    const Render r = render_all(atrium, cam);
    PipelineOptions cpu;
    cpu.backend = Backend::cpu;
    const SceneData data = prepare_scene(atrium);
    const std::vector<ReferenceHit> ref = trace_double_reference(atrium, data, cam, 0, false);
    auto agree = [&](ConstSpan<rf_pixel_hit> h, bool hit_miss) {
      if (h.empty()) return std::string("-");
      size_t n = 0;
      for (size_t i = 0; i < h.size(); ++i) {
        const bool hr = ref[i].instance != RF_INVALID, hh = h[i].instance != RF_INVALID;
        n += hit_miss ? hr != hh : (h[i].instance == ref[i].instance && h[i].primitive == ref[i].primitive);
      }
      return pct(static_cast<double>(n) / h.size());
    };
    std::snprintf(line, sizeof line, "| %.0e | %s | %s | %s | %s |\n", d, agree(r.rayfold, false).c_str(),
                  agree(r.rayfold, true).c_str(), agree(r.embree_flat, false).c_str(),
                  agree(r.embree_flat, true).c_str());
    out += line;
  }

  out += "\n## Mixed sizes: a room 2^101 across around the eye, the atrium 2^-60 of its size in front\n\n";
  {
    Scene mixed = scaled(atrium, std::ldexp(1.0, -80));
    Mesh room;
    room.name = "room";
    for (int c = 0; c < 8; ++c) room.positions.push_back(glm::vec3(c & 1 ? 1 : -1, c & 2 ? 1 : -1, c & 4 ? 1 : -1));
    room.indices = {0, 2, 3, 0, 3, 1, 4, 5, 7, 4, 7, 6, 0, 1, 5, 0, 5, 4,
                    2, 6, 7, 2, 7, 3, 0, 4, 6, 0, 6, 2, 1, 3, 7, 1, 7, 5};
    mixed.meshes.push_back(room);
    Xform big(1.0);
    big[0][0] = big[1][1] = big[2][2] = std::ldexp(1.0, 100);
    mixed.instances.push_back(Instance{static_cast<uint32_t>(mixed.meshes.size() - 1), big, "room"});
    const Camera cam = make_camera(scaled(view, std::ldexp(1.0, -80)), width, height);
    const Render r = render_all(mixed, cam);
    const uint32_t room_id = static_cast<uint32_t>(mixed.instances.size() - 1);
    auto on_atrium = [&](ConstSpan<rf_pixel_hit> h) {
      size_t n = 0;
      for (const rf_pixel_hit& p : h) n += p.instance != RF_INVALID && p.instance != room_id;
      return n;
    };
    std::snprintf(line, sizeof line,
                  "| | atrium pixels (alone: %zu) | room pixels |\n|---|---|---|\n| rayfold | %zu | %zu |\n",
                  hits(base.rayfold), on_atrium(r.rayfold), hits(r.rayfold) - on_atrium(r.rayfold));
    out += line;
    if (!r.embree_flat.empty()) {
      std::snprintf(line, sizeof line, "| Embree flat | %zu | %zu |\n| Embree instanced | %zu | %zu |\n",
                    on_atrium(r.embree_flat), hits(r.embree_flat) - on_atrium(r.embree_flat),
                    on_atrium(r.embree_instanced), hits(r.embree_instanced) - on_atrium(r.embree_instanced));
      out += line;
    }
  }
  std::fputs(out.c_str(), stdout);
  if (!md.empty()) write_text_file(md, out);
  if (!valid) {
    std::fprintf(stderr, "error: a power-of-two scale within 2^-100..2^100 changed rayfold's bits\n");
    return 3;
  }
  return 0;
}

}  // namespace
}  // namespace rayfold::core

int main(int argc, char** argv) {
  using namespace rayfold;
  using namespace rayfold::core;
  return cli::guarded_main([&] {
    int width = 320, height = 180;
    std::string md;
    cli::Args args(argc, argv, 1);
    while (!args.done()) {
      const std::string a = args.next();
      if (a == "--help" || a == "-h") {
        std::puts(
            "usage: rayfold-limits [--size WxH] [--md F]\n"
            "Where exactness ends: scales, distances and mixed sizes, rayfold beside Embree.");
        return 0;
      } else if (a == "--size") {
        cli::parse_size(a, args.value(a), &width, &height);
      } else if (a == "--md") {
        md = args.value(a);
        check_writable(md);
      } else {
        throw UsageError("unknown option '" + a + "' (see rayfold-limits --help)");
      }
    }
    return run(width, height, md);
  });
}
