// Building small glTF files by hand for the loader and bad-input tests: a
// JSON document plus one external .bin, written into a per-process temp dir.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <glm/vec3.hpp>
#include <nlohmann/json.hpp>

#include "scene/gltf_loader.h"

namespace rayfold::core::testing {

std::filesystem::path temp_dir();

struct GltfFile {
  std::vector<unsigned char> bin;
  nlohmann::json j = {{"asset", {{"version", "2.0"}}},
                      {"bufferViews", nlohmann::json::array()},
                      {"accessors", nlohmann::json::array()},
                      {"meshes", nlohmann::json::array()},
                      {"nodes", nlohmann::json::array()}};

  // Appends bytes as a new buffer view (4-byte aligned); returns its index.
  int view(const void* data, size_t bytes, size_t stride = 0);
  int accessor(int view, int component, const char* type, size_t count, size_t offset = 0);
  // A FLOAT VEC3 accessor with min and max; returns its index.
  int positions(const std::vector<glm::vec3>& p);
  // A one-triangle mesh 0 with u16 indices, and node 0 using it.
  void one_triangle(std::vector<uint16_t> indices = {0, 1, 2});
  // Writes NAME.gltf and NAME.bin; returns the .gltf path.
  std::string write(const std::string& name);
};

nlohmann::json prim(int position, int indices = -1, int mode = -1);
nlohmann::json mesh(std::vector<nlohmann::json> primitives);
nlohmann::json node_with_mesh(int m);

// Expects load_gltf(path) to throw InputError whose message names the file
// and contains `what`.
void expect_error(const std::string& path, const std::string& what);
// The same with load options.
void expect_error_with(const std::string& path, const LoadOptions& options, const std::string& what);

}  // namespace rayfold::core::testing
