// Compressed glTF geometry, decoded before the loader reads it:
// EXT_meshopt_compression / KHR_meshopt_compression buffer views
// (meshoptimizer, as gltfpack writes them) and KHR_draco_mesh_compression
// primitives (Draco). tinygltf, as Debian builds it, decodes neither and
// rejects some of their legal JSON, so the JSON is prepared first.
#pragma once

#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

namespace rayfold::core {

// What prepare_compressed_json changed, to be undone on the loaded model.
struct JsonFixups {
  // Index accessors without a buffer view (Draco's, whose data is in the
  // compressed stream) were pointed at an empty view appended at
  // placeholder_view, because tinygltf requires one; restore_fixups sets them
  // back to none and drops the view.
  std::vector<int> viewless_index_accessors;
  int placeholder_view = -1;
  // meshopt fallback buffers (byteLength, no data) given a 4-byte placeholder
  // tinygltf can load; their views must be decoded, never read.
  std::vector<int> fallback_buffers;
  // Images with neither a uri nor a buffer view (gltfpack writes such when
  // it cannot find a texture) were given a placeholder: tinygltf refuses
  // them, and rayfold never decodes images.
  size_t placeholder_images = 0;
  bool changed() const { return placeholder_view >= 0 || !fallback_buffers.empty() || placeholder_images > 0; }
};

// Prepares the JSON for tinygltf; returns what it changed.
JsonFixups prepare_json(nlohmann::json& gltf);

// Undoes the placeholder views on the loaded model.
void restore_fixups(tinygltf::Model& model, const JsonFixups& fixups);

// Replaces every meshopt-compressed buffer view's bytes with its decoded
// bytes (a new buffer each). Throws InputError(file, ...) naming the view for
// data that does not decode or an extension that is malformed.
void decode_meshopt_views(tinygltf::Model& model, const JsonFixups& fixups, const std::string& file);

// The accessors of every Draco-compressed primitive, decoded: accessor index
// -> its elements' components as glTF reads them (positions, joints, weights,
// indices). Throws InputError(file, ...) naming the primitive.
std::map<int, std::vector<double>> decode_draco_primitives(const tinygltf::Model& model, const std::string& file);

}  // namespace rayfold::core
