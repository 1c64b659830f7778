#include "scene/tangents.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <numeric>
#include <unordered_map>

#include <glm/geometric.hpp>

namespace rayfold::core {
namespace {

// A vertex as MikkTSpace welds it: position, normal, texture coordinates,
// by their bits.
struct VertexKey {
  float v[8];
  bool operator==(const VertexKey& o) const { return std::memcmp(v, o.v, sizeof v) == 0; }
};
struct VertexKeyHash {
  size_t operator()(const VertexKey& k) const {
    uint64_t h = 1469598103934665603ull;
    const unsigned char* b = reinterpret_cast<const unsigned char*>(k.v);
    for (size_t i = 0; i < sizeof k.v; ++i) h = (h ^ b[i]) * 1099511628211ull;
    return static_cast<size_t>(h);
  }
};

size_t root(std::vector<size_t>& parent, size_t x) {
  while (parent[x] != x) x = parent[x] = parent[parent[x]];
  return x;
}

glm::dvec3 unit_or_zero(const glm::dvec3& v) {
  const double length = glm::length(v);
  return length > 0.0 && std::isfinite(length) ? v / length : glm::dvec3(0.0);
}

}  // namespace

std::vector<glm::vec4> mikktspace_tangents(const glm::vec3* positions, const glm::vec3* normals,
                                           const glm::vec2* texcoords, const uint32_t* indices, size_t triangles) {
  const size_t corners = 3 * triangles;
  auto next = [](size_t c) { return c - c % 3 + (c % 3 + 1) % 3; };
  auto prev = [](size_t c) { return c - c % 3 + (c % 3 + 2) % 3; };
  // Welded vertices, per corner.
  std::vector<uint32_t> vertex(corners);
  std::unordered_map<VertexKey, uint32_t, VertexKeyHash> ids;
  for (size_t c = 0; c < corners; ++c) {
    const uint32_t i = indices[c];
    const glm::vec3 n = normals ? normals[i] : glm::vec3(0.0f);
    // + 0.0f: -0 and +0 are one value (MikkTSpace compares values, not bits).
    const VertexKey key{{positions[i].x + 0.0f, positions[i].y + 0.0f, positions[i].z + 0.0f, n.x + 0.0f, n.y + 0.0f,
                         n.z + 0.0f, texcoords[i].x + 0.0f, texcoords[i].y + 0.0f}};
    vertex[c] = ids.emplace(key, static_cast<uint32_t>(ids.size())).first->second;
  }
  auto position = [&](size_t c) { return glm::dvec3(positions[indices[c]]); };
  // Each triangle's tangent (unit, signed by its orientation) and orientation.
  std::vector<glm::dvec3> face_tangent(triangles, glm::dvec3(0.0));
  std::vector<char> oriented(triangles, 0), has(triangles, 0);
  std::vector<glm::dvec3> corner_normal(corners);
  for (size_t f = 0; f < triangles; ++f) {
    const glm::dvec3 d1 = position(3 * f + 1) - position(3 * f), d2 = position(3 * f + 2) - position(3 * f);
    auto uv = [&](size_t c) {
      const glm::vec2 t = texcoords[indices[c]];
      return glm::dvec2(t.x, -static_cast<double>(t.y));  // v upward (tangents.h)
    };
    const glm::dvec2 t1 = uv(3 * f + 1) - uv(3 * f), t2 = uv(3 * f + 2) - uv(3 * f);
    const double area = t1.x * t2.y - t1.y * t2.x;
    const glm::dvec3 face_normal = unit_or_zero(glm::cross(d1, d2));
    oriented[f] = area > 0.0;
    const glm::dvec3 os = unit_or_zero(t2.y * d1 - t1.y * d2);
    has[f] = area != 0.0 && std::isfinite(area) && os != glm::dvec3(0.0) && face_normal != glm::dvec3(0.0);
    face_tangent[f] = oriented[f] ? os : -os;
    for (size_t k = 0; k < 3; ++k) {
      const glm::dvec3 n = normals ? unit_or_zero(glm::dvec3(normals[indices[3 * f + k]])) : glm::dvec3(0.0);
      corner_normal[3 * f + k] = n == glm::dvec3(0.0) ? face_normal : n;
    }
  }
  // Groups: the corners of one vertex joined across the edges their
  // triangles share, wound alike, with the same orientation.
  std::vector<size_t> parent(corners);
  std::iota(parent.begin(), parent.end(), size_t{0});
  std::unordered_map<uint64_t, size_t> edge_start;  // (vertex a, vertex b) -> the corner at a
  auto edge = [&](size_t c) { return (static_cast<uint64_t>(vertex[c]) << 32) | vertex[next(c)]; };
  for (size_t c = 0; c < corners; ++c)
    if (has[c / 3]) edge_start.emplace(edge(c), c);
  for (size_t c = 0; c < corners; ++c) {
    if (!has[c / 3]) continue;
    const auto other = edge_start.find((static_cast<uint64_t>(vertex[next(c)]) << 32) | vertex[c]);
    if (other == edge_start.end() || oriented[other->second / 3] != oriented[c / 3]) continue;
    // The neighbour's corner at c's vertex follows its corner at c's next.
    parent[root(parent, c)] = root(parent, next(other->second));
    parent[root(parent, next(c))] = root(parent, other->second);
  }
  // Each group's angle-weighted sum of its triangles' projected tangents.
  std::vector<glm::dvec3> sum(corners, glm::dvec3(0.0));
  for (size_t c = 0; c < corners; ++c) {
    if (!has[c / 3]) continue;
    const glm::dvec3 n = corner_normal[c];
    auto in_plane = [&](const glm::dvec3& v) { return unit_or_zero(v - n * glm::dot(n, v)); };
    const glm::dvec3 t = in_plane(face_tangent[c / 3]);
    const glm::dvec3 e1 = in_plane(position(next(c)) - position(c)), e2 = in_plane(position(prev(c)) - position(c));
    const double angle = std::acos(std::clamp(glm::dot(e1, e2), -1.0, 1.0));
    sum[root(parent, c)] += angle * t;
  }
  std::vector<glm::vec4> out(corners, glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));
  std::vector<int64_t> some_corner(ids.size(), -1);  // per vertex, a corner with a tangent
  for (size_t c = 0; c < corners; ++c) {
    if (!has[c / 3]) continue;
    const glm::dvec3 t = unit_or_zero(sum[root(parent, c)]);
    if (t == glm::dvec3(0.0)) continue;
    out[c] = glm::vec4(glm::vec3(t), oriented[c / 3] ? 1.0f : -1.0f);
    if (some_corner[vertex[c]] < 0) some_corner[vertex[c]] = static_cast<int64_t>(c);
  }
  for (size_t c = 0; c < corners; ++c)
    if (!has[c / 3] && some_corner[vertex[c]] >= 0) out[c] = out[static_cast<size_t>(some_corner[vertex[c]])];
  return out;
}

}  // namespace rayfold::core
