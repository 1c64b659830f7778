#include "gltf_fixture.h"

#include <unistd.h>

#include <fstream>

#include <gtest/gtest.h>
#include <glm/common.hpp>

#include "scene/gltf_loader.h"
#include "test_util.h"
#include "util/errors.h"

namespace rayfold::core::testing {

namespace fs = std::filesystem;
using nlohmann::json;

fs::path temp_dir() { return scratch_dir("rayfold_gltf"); }

int GltfFile::view(const void* data, size_t bytes, size_t stride) {
  while (bin.size() % 4) bin.push_back(0);
  json v = {{"buffer", 0}, {"byteOffset", bin.size()}, {"byteLength", bytes}};
  if (stride) v["byteStride"] = stride;
  bin.insert(bin.end(), static_cast<const unsigned char*>(data), static_cast<const unsigned char*>(data) + bytes);
  j["bufferViews"].push_back(v);
  return static_cast<int>(j["bufferViews"].size()) - 1;
}

int GltfFile::accessor(int view, int component, const char* type, size_t count, size_t offset) {
  j["accessors"].push_back(
      {{"bufferView", view}, {"componentType", component}, {"type", type}, {"count", count}, {"byteOffset", offset}});
  return static_cast<int>(j["accessors"].size()) - 1;
}

int GltfFile::positions(const std::vector<glm::vec3>& p) {
  json& a = j["accessors"][accessor(view(p.data(), p.size() * 12), 5126, "VEC3", p.size())];
  glm::vec3 lo(INFINITY), hi(-INFINITY);
  for (auto& v : p) {
    lo = glm::min(lo, v);
    hi = glm::max(hi, v);
  }
  a["min"] = {lo.x, lo.y, lo.z};
  a["max"] = {hi.x, hi.y, hi.z};
  return static_cast<int>(j["accessors"].size()) - 1;
}

void GltfFile::one_triangle(std::vector<uint16_t> idx) {
  const int p = positions({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}});
  const int i = accessor(view(idx.data(), idx.size() * 2), 5123, "SCALAR", idx.size());
  j["meshes"] = json::array({mesh({prim(p, i)})});
  j["nodes"] = json::array({node_with_mesh(0)});
}

std::string GltfFile::write(const std::string& name) {
  const fs::path dir = temp_dir();
  if (!j.contains("buffers") && !bin.empty()) j["buffers"] = {{{"uri", name + ".bin"}, {"byteLength", bin.size()}}};
  std::ofstream(dir / (name + ".bin"), std::ios::binary).write(reinterpret_cast<const char*>(bin.data()), bin.size());
  std::ofstream(dir / (name + ".gltf")) << j.dump();
  return (dir / (name + ".gltf")).string();
}

json prim(int position, int indices, int mode) {
  json p;
  p["attributes"]["POSITION"] = position;
  if (indices >= 0) p["indices"] = indices;
  if (mode >= 0) p["mode"] = mode;
  return p;
}

json mesh(std::vector<json> primitives) {
  json m;
  m["primitives"] = primitives;
  return m;
}

json node_with_mesh(int m) {
  json n;
  n["mesh"] = m;
  return n;
}

void expect_error(const std::string& path, const std::string& what) { expect_error_with(path, {}, what); }

void expect_error_with(const std::string& path, const LoadOptions& options, const std::string& what) {
  try {
    load_gltf(path, nullptr, options);
    ADD_FAILURE() << path << ": loaded, expected an error containing '" << what << "'";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find(what), std::string::npos) << "expected '" << what << "' in: " << msg;
  }
}

}  // namespace rayfold::core::testing
