#include "scene_gen.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include <glm/gtc/matrix_transform.hpp>

#include "splitmix.h"

namespace rayfold::core {
namespace {

using Rng = SplitMix;

struct Builder {
  Mesh mesh;
  uint32_t vertex(double x, double y, double z) {
    mesh.positions.emplace_back(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
    return static_cast<uint32_t>(mesh.positions.size() - 1);
  }
  void tri(uint32_t a, uint32_t b, uint32_t c) { mesh.indices.insert(mesh.indices.end(), {a, b, c}); }
  void quad(uint32_t a, uint32_t b, uint32_t c, uint32_t d) {
    tri(a, b, c);
    tri(a, c, d);
  }
  // A closed box from lo to hi, each face split into n x n quads, outward
  // facing (counter-clockwise seen from outside).
  void box(glm::dvec3 lo, glm::dvec3 hi, int n) {
    for (int axis = 0; axis < 3; ++axis)
      for (int side = 0; side < 2; ++side) {
        const int u = (axis + 1) % 3, v = (axis + 2) % 3;
        const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
        for (int j = 0; j <= n; ++j)
          for (int i = 0; i <= n; ++i) {
            glm::dvec3 p;
            p[axis] = side ? hi[axis] : lo[axis];
            p[u] = lo[u] + (hi[u] - lo[u]) * i / n;
            p[v] = lo[v] + (hi[v] - lo[v]) * j / n;
            vertex(p.x, p.y, p.z);
          }
        for (int j = 0; j < n; ++j)
          for (int i = 0; i < n; ++i) {
            const uint32_t a = base + j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
            if (side)
              quad(a, b, c, d);
            else
              quad(a, d, c, b);
          }
      }
  }
  // A closed solid of revolution about +y through a profile of (radius, y)
  // points from bottom to top; both ends are capped.
  void lathe(const std::vector<glm::dvec2>& profile, int seg, glm::dvec3 at = glm::dvec3(0.0)) {
    const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
    const int rows = static_cast<int>(profile.size());
    for (int r = 0; r < rows; ++r)
      for (int s = 0; s < seg; ++s) {
        const double a = 2.0 * M_PI * s / seg;
        vertex(at.x + profile[r].x * std::cos(a), at.y + profile[r].y, at.z - profile[r].x * std::sin(a));
      }
    for (int r = 0; r + 1 < rows; ++r)
      for (int s = 0; s < seg; ++s) {
        const uint32_t a = base + r * seg + s, b = base + r * seg + (s + 1) % seg;
        quad(a, b, b + seg, a + seg);
      }
    const uint32_t bottom = vertex(at.x, at.y + profile.front().y, at.z);
    const uint32_t top = vertex(at.x, at.y + profile.back().y, at.z);
    for (int s = 0; s < seg; ++s) {
      tri(bottom, base + (s + 1) % seg, base + s);
      tri(top, base + (rows - 1) * seg + s, base + (rows - 1) * seg + (s + 1) % seg);
    }
  }
  void sphere(double radius, int seg, glm::dvec3 at = glm::dvec3(0.0)) {
    std::vector<glm::dvec2> profile;
    const int rings = std::max(2, seg / 2);
    for (int i = 1; i < rings; ++i) {
      const double a = M_PI * i / rings;
      profile.emplace_back(radius * std::sin(a), -radius * std::cos(a));
    }
    lathe(profile, seg, at);
  }
  // A semicircular arch in the xy plane spanning x in [-span/2, span/2],
  // rising from y = 0, with a square section of the given size.
  void arch(double span, double section, int seg) {
    const double r_in = span / 2.0 - section / 2.0, r_out = span / 2.0 + section / 2.0, h = section / 2.0;
    const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
    for (int s = 0; s <= seg; ++s) {
      const double a = M_PI * s / seg, c = std::cos(a), sn = std::sin(a);
      vertex(r_in * c, r_in * sn, -h);
      vertex(r_out * c, r_out * sn, -h);
      vertex(r_out * c, r_out * sn, h);
      vertex(r_in * c, r_in * sn, h);
    }
    for (int s = 0; s < seg; ++s)
      for (int k = 0; k < 4; ++k) {
        const uint32_t a = base + 4 * s + k, b = base + 4 * s + (k + 1) % 4;
        quad(a, a + 4, b + 4, b);
      }
    quad(base + 0, base + 1, base + 2, base + 3);
    const uint32_t e = base + 4 * seg;
    quad(e + 3, e + 2, e + 1, e + 0);
  }
};

using Template = std::function<Mesh(int detail)>;

Mesh named(Builder&& b, const char* name) {
  b.mesh.name = name;
  return std::move(b.mesh);
}

std::vector<std::pair<const char*, Template>> clutter_templates() {
  return {
      {"crate",
       [](int d) {
         Builder b;
         b.box({-0.5, 0.0, -0.5}, {0.5, 1.0, 0.5}, std::max(1, d / 2));
         return named(std::move(b), "crate");
       }},
      {"ball",
       [](int d) {
         Builder b;
         b.sphere(0.5, 4 * d, {0.0, 0.5, 0.0});
         return named(std::move(b), "ball");
       }},
      {"vase",
       [](int d) {
         Builder b;
         std::vector<glm::dvec2> p;
         const int n = 2 * d + 2;
         for (int i = 0; i <= n; ++i) {
           const double y = 1.2 * i / n;
           p.emplace_back(0.18 + 0.22 * std::sin(M_PI * y / 1.2 * 1.3) * (1.0 - 0.3 * y), y);
         }
         b.lathe(p, 4 * d);
         return named(std::move(b), "vase");
       }},
      {"table",
       [](int d) {
         Builder b;
         const int n = std::max(1, d / 3);
         b.box({-0.8, 0.72, -0.5}, {0.8, 0.78, 0.5}, n);
         for (int i = 0; i < 4; ++i) {
           const double x = (i & 1) ? 0.7 : -0.7, z = (i & 2) ? 0.4 : -0.4;
           b.lathe({{0.04, 0.0}, {0.05, 0.36}, {0.04, 0.72}}, 2 * d, {x, 0.0, z});
         }
         return named(std::move(b), "table");
       }},
      {"bench",
       [](int d) {
         Builder b;
         const int n = std::max(1, d / 3);
         b.box({-1.0, 0.4, -0.25}, {1.0, 0.48, 0.25}, n);
         b.box({-0.95, 0.0, -0.2}, {-0.85, 0.4, 0.2}, n);
         b.box({0.85, 0.0, -0.2}, {0.95, 0.4, 0.2}, n);
         return named(std::move(b), "bench");
       }},
      {"planter",
       [](int d) {
         Builder b;
         b.lathe({{0.5, 0.0}, {0.6, 0.6}, {0.62, 0.65}}, 4 * d);
         b.sphere(0.55, 4 * d, {0.0, 1.1, 0.0});
         return named(std::move(b), "planter");
       }},
  };
}

}  // namespace

Scene generate_atrium(const GenOptions& opt) {
  const int objects = std::max(1, opt.objects);

  auto build = [&](int detail) {
    Rng rng(opt.seed);
    Scene scene;
    auto add_mesh = [&](Mesh m) {
      scene.meshes.push_back(std::move(m));
      return static_cast<uint32_t>(scene.meshes.size() - 1);
    };
    auto place = [&](uint32_t mesh, const Xform& m, const std::string& name) {
      if (static_cast<int>(scene.instances.size()) >= objects) return;
      scene.instances.push_back({mesh, m, name});
    };
    auto at = [](double x, double y, double z) { return glm::translate(Xform(1.0), glm::dvec3(x, y, z)); };

    // Architecture: floor, walls, galleries.
    {
      Builder b;
      b.box({-20.0, -0.2, -10.0}, {20.0, 0.0, 10.0}, 2 * detail);
      place(add_mesh(named(std::move(b), "floor")), Xform(1.0), "floor");
    }
    if (objects >= 8) {
      Builder wall_x, wall_z, gallery;
      wall_x.box({-20.0, 0.0, -0.25}, {20.0, 15.0, 0.25}, detail);
      wall_z.box({-0.25, 0.0, -10.0}, {0.25, 15.0, 10.0}, detail);
      gallery.box({-19.5, 5.7, -1.5}, {19.5, 6.0, 1.5}, detail);
      const uint32_t wx = add_mesh(named(std::move(wall_x), "wall_long"));
      const uint32_t wz = add_mesh(named(std::move(wall_z), "wall_short"));
      const uint32_t g = add_mesh(named(std::move(gallery), "gallery"));
      place(wx, at(0.0, 0.0, -10.25), "wall_north");
      place(wx, at(0.0, 0.0, 10.25), "wall_south");
      place(wz, at(-20.25, 0.0, 0.0), "wall_west");
      place(wz, at(20.25, 0.0, 0.0), "wall_east");
      place(g, at(0.0, 0.0, -8.5), "gallery_north");
      place(g, at(0.0, 0.0, 8.5), "gallery_south");
    }
    // Rows of columns and arches on two levels.
    const int per_row = std::clamp((objects - 7) / 10, 0, 9);
    if (per_row > 0) {
      Builder col, arch;
      col.box({-0.45, 0.0, -0.45}, {0.45, 0.3, 0.45}, 1);
      col.lathe({{0.3, 0.3}, {0.27, 2.5}, {0.3, 4.7}, {0.42, 5.0}}, 4 * detail);
      arch.arch(3.4, 0.4, 4 * detail);
      const uint32_t c = add_mesh(named(std::move(col), "column"));
      const uint32_t a = add_mesh(named(std::move(arch), "arch"));
      for (int level = 0; level < 2; ++level)
        for (int side = -1; side <= 1; side += 2) {
          const double y = level ? 6.0 : 0.0, s = level ? 0.8 : 1.0, z = side * 6.5;
          for (int i = 0; i < per_row; ++i) {
            const double x = -16.0 + 32.0 * i / std::max(1, per_row - 1);
            place(c, at(x, y, z) * glm::scale(Xform(1.0), glm::dvec3(1.0, s, 1.0)), "column");
          }
          for (int i = 0; i + 1 < per_row; ++i) {
            const double x0 = -16.0 + 32.0 * i / (per_row - 1), x1 = -16.0 + 32.0 * (i + 1) / (per_row - 1);
            const double span = x1 - x0;
            place(a, at(0.5 * (x0 + x1), y + 5.0 * s, z) * glm::scale(Xform(1.0), glm::dvec3(span / 3.4, s, 1.0)),
                  "arch");
          }
        }
    }
    // A statue in the middle straddles the image centre of the default view.
    if (objects >= 4) {
      Builder statue;
      std::vector<glm::dvec2> p;
      const int n = 6 * detail;
      for (int i = 0; i <= n; ++i) {
        const double y = 3.5 * i / n;
        p.emplace_back(0.6 + 0.35 * std::sin(5.0 * y) * std::exp(-0.2 * y), y);
      }
      statue.lathe(p, 8 * detail);
      statue.sphere(0.7, 8 * detail, {0.0, 4.1, 0.0});
      place(add_mesh(named(std::move(statue), "statue")), at(2.0, 0.0, 0.0), "statue");
    }
    // Clutter of very different sizes, some along the centre line.
    std::vector<uint32_t> kinds;
    for (auto& [name, make] : clutter_templates()) kinds.push_back(add_mesh(make(detail)));
    for (int i = 0; static_cast<int>(scene.instances.size()) < objects; ++i) {
      const uint32_t mesh = kinds[rng.below(static_cast<int>(kinds.size()))];
      const double x = rng.uniform(-19.0, 19.0);
      const double z = (i % 5 == 0) ? rng.uniform(-0.8, 0.8) : rng.uniform(-9.5, 9.5);
      const double size = std::exp(rng.uniform(std::log(0.2), std::log(3.0)));
      const double yaw = rng.uniform(0.0, 2.0 * M_PI);
      const bool gallery = objects >= 8 && rng.below(6) == 0;
      const double y = gallery ? 6.0 : 0.0;
      const double gz = gallery ? (rng.below(2) ? 8.5 : -8.5) + rng.uniform(-1.0, 1.0) : z;
      const Xform m = at(x, y, gz) * glm::rotate(Xform(1.0), yaw, glm::dvec3(0.0, 1.0, 0.0)) *
                      glm::scale(Xform(1.0), glm::dvec3(size));
      place(mesh, m, scene.meshes[mesh].name);
    }
    // Drop meshes no instance uses (small object counts), keeping ids dense.
    std::vector<int> remap(scene.meshes.size(), -1);
    std::vector<Mesh> used;
    for (Instance& inst : scene.instances) {
      if (remap[inst.mesh] < 0) {
        remap[inst.mesh] = static_cast<int>(used.size());
        used.push_back(scene.meshes[inst.mesh]);
      }
      inst.mesh = static_cast<uint32_t>(remap[inst.mesh]);
    }
    scene.meshes = std::move(used);
    CameraSpec cam;
    cam.eye = {-17.5, 3.0, 0.5};
    cam.look_at = {12.0, 3.5, 0.0};
    cam.vfov_degrees = 60.0;
    scene.camera = cam;
    return scene;
  };

  // The largest detail level whose scene stays within the triangle budget.
  int lo = 1, hi = 64;
  while (lo < hi) {
    const int mid = (lo + hi + 1) / 2;
    if (build(mid).triangle_count() <= opt.triangle_budget)
      lo = mid;
    else
      hi = mid - 1;
  }
  return build(lo);
}

}  // namespace rayfold::core
