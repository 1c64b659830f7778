#include "scene/gltf_decompress.h"

#include <draco/compression/decode.h>
#include <meshoptimizer.h>

#include <algorithm>

#include "util/errors.h"

namespace rayfold::core {
namespace {

const char* const kMeshoptExtensions[] = {"EXT_meshopt_compression", "KHR_meshopt_compression"};

// The view's meshopt extension, or null.
const tinygltf::Value* meshopt_extension(const tinygltf::ExtensionMap& extensions, std::string* name) {
  for (const char* e : kMeshoptExtensions) {
    const auto it = extensions.find(e);
    if (it != extensions.end()) {
      *name = e;
      return &it->second;
    }
  }
  return nullptr;
}

// A non-negative integer member of an extension object, or `fallback` when
// absent; InputError naming it otherwise.
size_t member(const tinygltf::Value& v, const char* key, const std::string& where, const std::string& file,
              long long fallback = -1) {
  if (!v.Has(key)) {
    if (fallback >= 0) return static_cast<size_t>(fallback);
    throw InputError(file, where + " has no " + key);
  }
  const tinygltf::Value& m = v.Get(key);
  if (!m.IsNumber() && !m.IsInt()) throw InputError(file, where + ": " + key + " is not a number");
  const double d = m.GetNumberAsDouble();
  if (!(d >= 0.0 && d <= 4294967295.0) || d != static_cast<double>(static_cast<long long>(d)))
    throw InputError(file, where + ": " + key + " is not a non-negative integer");
  return static_cast<size_t>(d);
}

std::string string_member(const tinygltf::Value& v, const char* key, const std::string& fallback) {
  return v.Has(key) && v.Get(key).IsString() ? v.Get(key).Get<std::string>() : fallback;
}

}  // namespace

JsonFixups prepare_json(nlohmann::json& j) {
  JsonFixups fix;
  const auto images = j.find("images");
  if (images != j.end() && images->is_array())
    for (nlohmann::json& im : *images)
      if (im.is_object() && !im.contains("uri") && !im.contains("bufferView")) {
        im["uri"] = "data:application/octet-stream;base64,AAAA";
        ++fix.placeholder_images;
      }
  const auto buffers = j.find("buffers");
  if (buffers != j.end() && buffers->is_array())
    for (size_t i = 0; i < buffers->size(); ++i) {
      nlohmann::json& b = (*buffers)[i];
      if (!b.is_object() || b.contains("uri") || !b.contains("extensions") || !b["extensions"].is_object()) continue;
      for (const char* e : kMeshoptExtensions) {
        const auto ext = b["extensions"].find(e);
        if (ext != b["extensions"].end() && ext->is_object() && ext->value("fallback", false) == true) {
          b = {{"byteLength", 4}, {"uri", "data:application/octet-stream;base64,AAAAAA=="}};
          fix.fallback_buffers.push_back(static_cast<int>(i));
          break;
        }
      }
    }
  const auto meshes = j.find("meshes");
  const auto accessors = j.find("accessors");
  if (meshes == j.end() || !meshes->is_array() || accessors == j.end() || !accessors->is_array() ||
      buffers == j.end() || !buffers->is_array() || buffers->empty())
    return fix;
  for (const nlohmann::json& m : *meshes) {
    if (!m.is_object() || !m.contains("primitives") || !m["primitives"].is_array()) continue;
    for (const nlohmann::json& p : m["primitives"]) {
      if (!p.is_object() || !p.contains("indices") || !p["indices"].is_number_integer()) continue;
      const long long a = p["indices"].get<long long>();
      if (a < 0 || static_cast<size_t>(a) >= accessors->size()) continue;
      nlohmann::json& acc = (*accessors)[a];
      if (!acc.is_object() || acc.contains("bufferView")) continue;
      if (fix.placeholder_view < 0) {
        nlohmann::json& views = j["bufferViews"];
        if (!views.is_array()) views = nlohmann::json::array();
        views.push_back({{"buffer", 0}, {"byteLength", 4}});
        fix.placeholder_view = static_cast<int>(views.size() - 1);
      }
      acc["bufferView"] = fix.placeholder_view;
      fix.viewless_index_accessors.push_back(static_cast<int>(a));
    }
  }
  std::sort(fix.viewless_index_accessors.begin(), fix.viewless_index_accessors.end());
  fix.viewless_index_accessors.erase(
      std::unique(fix.viewless_index_accessors.begin(), fix.viewless_index_accessors.end()),
      fix.viewless_index_accessors.end());
  return fix;
}

void restore_fixups(tinygltf::Model& model, const JsonFixups& fix) {
  if (fix.placeholder_view < 0) return;
  for (int a : fix.viewless_index_accessors) model.accessors[a].bufferView = -1;
  if (static_cast<size_t>(fix.placeholder_view) + 1 == model.bufferViews.size()) model.bufferViews.pop_back();
}

void decode_meshopt_views(tinygltf::Model& model, const JsonFixups& fix, const std::string& file) {
  for (size_t vi = 0; vi < model.bufferViews.size(); ++vi) {
    tinygltf::BufferView& view = model.bufferViews[vi];
    std::string name;
    const tinygltf::Value* ext = meshopt_extension(view.extensions, &name);
    if (!ext) continue;
    const std::string where = "buffer view " + std::to_string(vi) + " (" + name + ")";
    if (!ext->IsObject()) throw InputError(file, where + " is not an object");
    const size_t buffer = member(*ext, "buffer", where, file);
    const size_t offset = member(*ext, "byteOffset", where, file, 0);
    const size_t length = member(*ext, "byteLength", where, file);
    const size_t stride = member(*ext, "byteStride", where, file);
    const size_t count = member(*ext, "count", where, file);
    const std::string mode = string_member(*ext, "mode", "");
    const std::string filter = string_member(*ext, "filter", "NONE");
    if (buffer >= model.buffers.size()) throw InputError(file, where + " refers to a buffer that does not exist");
    if (std::find(fix.fallback_buffers.begin(), fix.fallback_buffers.end(), static_cast<int>(buffer)) !=
        fix.fallback_buffers.end())
      throw InputError(file, where + " reads its compressed data from a fallback buffer, which holds none");
    const std::vector<unsigned char>& src = model.buffers[buffer].data;
    if (offset > src.size() || length > src.size() - offset)
      throw InputError(file, where + ": compressed bytes " + std::to_string(offset) + " + " + std::to_string(length) +
                                 " run past its buffer of " + std::to_string(src.size()) + " bytes");
    // The decoded bytes are the view's: count elements of byteStride.
    if (stride == 0 || count > view.byteLength / stride)
      throw InputError(file, where + ": " + std::to_string(count) + " elements of " + std::to_string(stride) +
                                 " bytes do not fit the view's " + std::to_string(view.byteLength) + " bytes");
    std::vector<unsigned char> out(view.byteLength, 0);
    const unsigned char* data = src.data() + offset;
    int rc = -1;
    if (mode == "ATTRIBUTES") {
      if (stride % 4 != 0 || stride > 256)
        throw InputError(file, where + ": ATTRIBUTES need a byteStride that is a multiple of 4 up to 256");
      rc = meshopt_decodeVertexBuffer(out.data(), count, stride, data, length);
    } else if (mode == "TRIANGLES" || mode == "INDICES") {
      if (stride != 2 && stride != 4) throw InputError(file, where + ": indices need a byteStride of 2 or 4");
      if (mode == "TRIANGLES" && count % 3 != 0)
        throw InputError(file, where + ": TRIANGLES need a count that is a multiple of 3");
      rc = mode == "TRIANGLES" ? meshopt_decodeIndexBuffer(out.data(), count, stride, data, length)
                               : meshopt_decodeIndexSequence(out.data(), count, stride, data, length);
    } else {
      throw InputError(file, where + ": mode '" + mode + "' is not ATTRIBUTES, TRIANGLES or INDICES");
    }
    if (rc != 0)
      throw InputError(file, where + ": the compressed data does not decode (meshoptimizer error " +
                                 std::to_string(rc) + ")");
    if (filter != "NONE") {
      if (mode != "ATTRIBUTES") throw InputError(file, where + ": filter " + filter + " on indices");
      if (filter == "OCTAHEDRAL" && (stride == 4 || stride == 8))
        meshopt_decodeFilterOct(out.data(), count, stride);
      else if (filter == "QUATERNION" && stride == 8)
        meshopt_decodeFilterQuat(out.data(), count, stride);
      else if (filter == "EXPONENTIAL")
        meshopt_decodeFilterExp(out.data(), count, stride);
      else
        throw InputError(file, where + ": filter '" + filter + "' with byteStride " + std::to_string(stride) +
                                   " is not one glTF defines");
    }
    tinygltf::Buffer decoded;
    decoded.data = std::move(out);
    model.buffers.push_back(std::move(decoded));
    view.buffer = static_cast<int>(model.buffers.size() - 1);
    view.byteOffset = 0;
    view.extensions.erase(name);
  }
}

std::map<int, std::vector<double>> decode_draco_primitives(const tinygltf::Model& model, const std::string& file) {
  std::map<int, std::vector<double>> out;
  for (size_t mi = 0; mi < model.meshes.size(); ++mi)
    for (size_t pi = 0; pi < model.meshes[mi].primitives.size(); ++pi) {
      const tinygltf::Primitive& prim = model.meshes[mi].primitives[pi];
      const auto it = prim.extensions.find("KHR_draco_mesh_compression");
      if (it == prim.extensions.end()) continue;
      const std::string where =
          "mesh " + std::to_string(mi) + " primitive " + std::to_string(pi) + " (KHR_draco_mesh_compression)";
      const tinygltf::Value& ext = it->second;
      if (!ext.IsObject()) throw InputError(file, where + " is not an object");
      const size_t vi = member(ext, "bufferView", where, file);
      if (vi >= model.bufferViews.size()) throw InputError(file, where + " refers to a buffer view that does not exist");
      const tinygltf::BufferView& view = model.bufferViews[vi];
      if (view.buffer < 0 || static_cast<size_t>(view.buffer) >= model.buffers.size())
        throw InputError(file, where + ": its buffer view refers to a buffer that does not exist");
      const std::vector<unsigned char>& src = model.buffers[view.buffer].data;
      if (view.byteOffset > src.size() || view.byteLength > src.size() - view.byteOffset)
        throw InputError(file, where + ": its buffer view runs past its buffer");
      draco::DecoderBuffer buffer;
      buffer.Init(reinterpret_cast<const char*>(src.data() + view.byteOffset), view.byteLength);
      draco::Decoder decoder;
      auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
      if (!decoded.ok())
        throw InputError(file, where + ": the compressed data does not decode (" +
                                   decoded.status().error_msg_string() + ")");
      const std::unique_ptr<draco::Mesh> mesh = std::move(decoded).value();
      const size_t points = mesh->num_points();
      auto store = [&](int accessor, std::vector<double>&& values, size_t count, const std::string& what) {
        if (accessor < 0 || static_cast<size_t>(accessor) >= model.accessors.size())
          throw InputError(file, where + ": " + what + " accessor does not exist");
        if (model.accessors[accessor].count != count)
          throw InputError(file, where + ": " + what + " accessor " + std::to_string(accessor) + " has " +
                                     std::to_string(model.accessors[accessor].count) + " elements, the Draco data " +
                                     std::to_string(count));
        const auto slot = out.find(accessor);
        if (slot == out.end())
          out.emplace(accessor, std::move(values));
        else if (slot->second != values)
          throw InputError(file, where + ": accessor " + std::to_string(accessor) +
                                     " is decoded differently by two primitives");
      };
      if (!ext.Has("attributes") || !ext.Get("attributes").IsObject())
        throw InputError(file, where + " has no attributes object");
      const tinygltf::Value& attributes = ext.Get("attributes");
      for (const std::string& semantic : attributes.Keys()) {
        const auto a = prim.attributes.find(semantic);
        if (a == prim.attributes.end())
          throw InputError(file, where + ": attribute " + semantic + " is compressed but not in the primitive");
        const size_t id = member(attributes, semantic.c_str(), where, file);
        const draco::PointAttribute* attr = mesh->GetAttributeByUniqueId(static_cast<uint32_t>(id));
        if (!attr) throw InputError(file, where + ": the Draco data has no attribute " + std::to_string(id));
        const int components = attr->num_components();
        if (components < 1 || components > 4)
          throw InputError(file, where + ": attribute " + semantic + " has " + std::to_string(components) +
                                     " components");
        std::vector<double> values(points * components);
        float v[4];
        for (draco::PointIndex p(0); p < static_cast<uint32_t>(points); ++p) {
          if (!attr->ConvertValue<float>(attr->mapped_index(p), static_cast<int8_t>(components), v))
            throw InputError(file, where + ": attribute " + semantic + " does not convert to numbers");
          for (int c = 0; c < components; ++c) values[p.value() * components + c] = v[c];
        }
        store(a->second, std::move(values), points, semantic);
      }
      if (prim.indices >= 0) {
        std::vector<double> indices(3 * static_cast<size_t>(mesh->num_faces()));
        for (draco::FaceIndex f(0); f < mesh->num_faces(); ++f)
          for (int c = 0; c < 3; ++c) indices[3 * f.value() + c] = mesh->face(f)[c].value();
        store(prim.indices, std::move(indices), 3 * static_cast<size_t>(mesh->num_faces()), "indices");
      }
    }
  return out;
}

}  // namespace rayfold::core
