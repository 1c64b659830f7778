#include "scene/gltf_loader.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>

#include <tiny_gltf.h>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>

#include "scene/gltf_decompress.h"
#include "util/errors.h"

namespace rayfold::core {
namespace {

// Hit info needs no pixels: images are neither decoded nor required.
bool skip_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;
}

// External buffers are read only from regular files: a URI naming a device
// or a pipe (/dev/zero, a FIFO) would otherwise hang the loader or exhaust
// memory. Files are otherwise read as tinygltf would.
bool read_regular_file(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* user) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    if (err) *err += "'" + path + "' is not a regular file\n";
    return false;
  }
  return tinygltf::ReadWholeFile(out, err, path, user);
}

// Required extensions that change nothing about geometry can be ignored;
// any other one changes how positions or indices are stored.
bool geometry_neutral(const std::string& ext) {
  static const char* prefixes[] = {"KHR_materials_", "KHR_texture_", "EXT_texture_", "KHR_lights_", "MSFT_texture_"};
  for (const char* p : prefixes)
    if (ext.rfind(p, 0) == 0) return true;
  // Read: integer positions are converted as glTF says; GPU instances become
  // instances.
  // Decoded (gltf_decompress.h): meshopt buffer views and Draco primitives.
  return ext == "KHR_mesh_quantization" || ext == "EXT_mesh_gpu_instancing" || ext == "EXT_meshopt_compression" ||
         ext == "KHR_meshopt_compression" || ext == "KHR_draco_mesh_compression";
}

class Loader {
 public:
  Loader(const std::string& path, std::vector<std::string>* warnings, const LoadOptions& options)
      : path_(path), warnings_(warnings), options_(options) {}

  // Reads and checks the file: once.
  void open() {
    read_model();
    check_extensions();
    rest_nodes_ = model_.nodes;
  }

  // The scene posed at `time` (NaN: at rest); any number of times. Warnings
  // are reported for the first only.
  Scene build(double time) {
    scene_ = Scene{};
    mesh_slot_.clear();
    parent_.clear();
    model_.nodes = rest_nodes_;
    if (!std::isnan(time)) pose_at(time);
    std::vector<int> roots = root_nodes();
    // Depth-first over the hierarchy with an explicit stack; `on_path` finds
    // cycles, `visited` nodes reachable twice (a DAG is not a tree either).
    struct Item {
      int node;
      Xform world_from_parent;
      bool leaving;
    };
    std::vector<Item> stack;
    for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.push_back({*it, Xform(1.0), false});
    std::vector<char> on_path(model_.nodes.size(), 0), visited(model_.nodes.size(), 0);
    while (!stack.empty()) {
      Item item = stack.back();
      stack.pop_back();
      if (item.leaving) {
        on_path[item.node] = 0;
        continue;
      }
      const int ni = item.node;
      if (ni < 0 || static_cast<size_t>(ni) >= model_.nodes.size())
        fail("a node reference (" + std::to_string(ni) + ") is out of range");
      if (on_path[ni]) fail("node " + std::to_string(ni) + " is its own ancestor (a cycle in the node hierarchy)");
      if (visited[ni]) fail("node " + std::to_string(ni) + " has more than one parent");
      visited[ni] = 1;
      on_path[ni] = 1;
      const tinygltf::Node& node = model_.nodes[ni];
      const Xform world_from_node = item.world_from_parent * local_transform(ni);
      if (node.mesh >= 0)
        add_instance(ni, world_from_node);
      else if (node.mesh < -1)
        fail("node " + std::to_string(ni) + " has a negative mesh index");
      if (node.camera >= 0) add_camera(ni, world_from_node);
      stack.push_back({ni, Xform(1.0), true});
      for (auto it = node.children.rbegin(); it != node.children.rend(); ++it)
        stack.push_back({*it, world_from_node, false});
    }
    choose_camera();
    if (scene_.triangle_count() == 0) warn("the scene has no triangles; every pixel will miss");
    flush_warnings();
    warnings_ = nullptr;
    pending_.clear();
    return std::move(scene_);
  }

  void cache_meshes(bool on) { cache_meshes_ = on; }

  // The last keyframe time over the node animations; NaN without any.
  double animation_end() const {
    double end = NAN;
    for (size_t ai = 0; ai < model_.animations.size(); ++ai)
      for (const tinygltf::AnimationChannel& ch : model_.animations[ai].channels) {
        if (ch.target_node < 0 || ch.sampler < 0 ||
            static_cast<size_t>(ch.sampler) >= model_.animations[ai].samplers.size())
          continue;
        const std::vector<double> keys = read_elements(model_.animations[ai].samplers[ch.sampler].input,
                                                       "animation " + std::to_string(ai) + " input", 1, false);
        if (!keys.empty()) end = std::isnan(end) ? keys.back() : std::max(end, keys.back());
      }
    return end;
  }

 private:
  [[noreturn]] void fail(const std::string& what) const { throw InputError(path_, what); }
  // One line per kind of warning: the first case, and how many more there
  // are. The kind is the message up to its first digit ("node 7 has a zero
  // scale" and "node 9 has a zero scale" are one kind).
  void warn(const std::string& what) {
    std::string kind;
    for (char c : what) kind += (c >= '0' && c <= '9') ? '#' : c;
    for (Warning& w : pending_)
      if (w.kind == kind) {
        ++w.more;
        return;
      }
    pending_.push_back({kind, what, 0});
  }
  void flush_warnings() {
    if (!warnings_) return;
    for (const Warning& w : pending_)
      warnings_->push_back(path_ + ": " + w.first +
                           (w.more ? " (and " + std::to_string(w.more) + " more like it)" : std::string()));
  }

  // A file that is neither GLB nor JSON is some other format: say which, if
  // its extension tells, rather than report a JSON syntax error.
  void check_json_start(const std::string& bytes) const {
    const size_t first = bytes.find_first_not_of(" \t\r\n");
    if (first != std::string::npos && bytes[first] == '{') return;
    std::string ext = std::filesystem::path(path_).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    static const std::pair<const char*, const char*> formats[] = {
        {".obj", "an OBJ file"},    {".ply", "a PLY file"},       {".fbx", "an FBX file"}, {".stl", "an STL file"},
        {".dae", "a COLLADA file"}, {".usd", "a USD file"},       {".usda", "a USD file"}, {".usdz", "a USD file"},
        {".3ds", "a 3DS file"},     {".blend", "a Blender file"}, {".off", "an OFF file"}};
    std::string what = "not a glTF file";
    for (const auto& [e, name] : formats)
      if (ext == e) what = std::string("not a glTF file but ") + name;
    fail(what +
         " (rayfold reads glTF 2.0, .gltf or .glb; other formats can be converted, for example with "
         "Blender or assimp export)");
  }

  // tinygltf reads a member of the wrong JSON type as absent: "primitives"
  // written as an object gives a mesh without triangles, silently. Every
  // member rayfold's reading depends on is checked against the glTF 2.0
  // schema's type, and a mismatch names its path.
  void check_schema_types(const nlohmann::json& j) const {
    using json = nlohmann::json;
    enum Kind { kInt, kNumber, kString, kArray, kObject, kIntArray, kNumberArray, kObjectArray };
    auto is = [](const json& v, Kind k) {
      auto all = [&](auto pred) {
        if (!v.is_array()) return false;
        for (const json& e : v)
          if (!pred(e)) return false;
        return true;
      };
      switch (k) {
        case kInt: return v.is_number_integer();
        case kNumber: return v.is_number();
        case kString: return v.is_string();
        case kArray: return v.is_array();
        case kObject: return v.is_object();
        case kIntArray: return all([](const json& e) { return e.is_number_integer(); });
        case kNumberArray: return all([](const json& e) { return e.is_number(); });
        case kObjectArray: return all([](const json& e) { return e.is_object(); });
      }
      return false;
    };
    static const char* names[] = {
        "an integer",          "a number",           "a string", "an array", "an object", "an array of integers",
        "an array of numbers", "an array of objects"};
    auto check = [&](const json& obj, const std::string& path, std::initializer_list<std::pair<const char*, Kind>> m) {
      for (const auto& [key, kind] : m) {
        const auto it = obj.find(key);
        if (it != obj.end() && !is(*it, kind))
          fail(path + "." + key + " must be " + names[kind] + " (glTF 2.0 schema), not " + it->type_name());
      }
    };
    check(j, "",
          {{"scene", kInt},
           {"scenes", kObjectArray},
           {"nodes", kObjectArray},
           {"meshes", kObjectArray},
           {"accessors", kObjectArray},
           {"bufferViews", kObjectArray},
           {"buffers", kObjectArray},
           {"cameras", kObjectArray},
           {"skins", kObjectArray},
           {"extensionsRequired", kArray},
           {"extensionsUsed", kArray}});
    auto each = [&](const char* array, auto fn) {
      const auto it = j.find(array);
      if (it == j.end()) return;
      for (size_t i = 0; i < it->size(); ++i) fn((*it)[i], std::string(array) + "[" + std::to_string(i) + "]");
    };
    each("scenes", [&](const json& o, const std::string& p) {
      check(o, p, {{"nodes", kIntArray}, {"name", kString}});
    });
    each("nodes", [&](const json& o, const std::string& p) {
      check(o, p,
            {{"mesh", kInt},
             {"camera", kInt},
             {"skin", kInt},
             {"children", kIntArray},
             {"matrix", kNumberArray},
             {"translation", kNumberArray},
             {"rotation", kNumberArray},
             {"scale", kNumberArray},
             {"name", kString}});
    });
    each("meshes", [&](const json& o, const std::string& p) {
      check(o, p, {{"primitives", kObjectArray}, {"weights", kNumberArray}, {"name", kString}});
      const auto prims = o.find("primitives");
      if (prims == o.end()) return;
      for (size_t i = 0; i < prims->size(); ++i) {
        const std::string pp = p + ".primitives[" + std::to_string(i) + "]";
        check((*prims)[i], pp, {{"attributes", kObject}, {"indices", kInt}, {"mode", kInt}, {"targets", kObjectArray}});
        const auto attrs = (*prims)[i].find("attributes");
        if (attrs != (*prims)[i].end()) check(*attrs, pp + ".attributes", {{"POSITION", kInt}});
      }
    });
    each("accessors", [&](const json& o, const std::string& p) {
      check(o, p,
            {{"bufferView", kInt},
             {"byteOffset", kInt},
             {"componentType", kInt},
             {"count", kInt},
             {"type", kString},
             {"sparse", kObject},
             {"min", kNumberArray},
             {"max", kNumberArray}});
    });
    each("skins", [&](const json& o, const std::string& p) {
      check(o, p, {{"joints", kIntArray}, {"inverseBindMatrices", kInt}, {"skeleton", kInt}});
    });
    each("bufferViews", [&](const json& o, const std::string& p) {
      check(o, p, {{"buffer", kInt}, {"byteOffset", kInt}, {"byteLength", kInt}, {"byteStride", kInt}});
    });
    each("buffers", [&](const json& o, const std::string& p) {
      check(o, p, {{"uri", kString}, {"byteLength", kInt}});
    });
    each("cameras", [&](const json& o, const std::string& p) {
      check(o, p, {{"type", kString}, {"perspective", kObject}, {"orthographic", kObject}});
      const auto persp = o.find("perspective");
      if (persp != o.end()) check(*persp, p + ".perspective", {{"yfov", kNumber}, {"aspectRatio", kNumber}});
    });
  }

  // What tinygltf does not check: the GLB header's version and length, and
  // nodes that carry both a matrix and TRS (tinygltf silently drops the TRS).
  // Returns the parsed JSON (discarded when it does not parse) and, for a
  // GLB, sets *bin_offset to where the chunks after the JSON start.
  nlohmann::json check_raw(const std::string& bytes, size_t* bin_offset) const {
    std::string json_text = bytes;
    if (binary_) {
      if (bytes.size() < 20) fail("the GLB header is truncated");
      uint32_t version, length, chunk_length, chunk_type;
      std::memcpy(&version, &bytes[4], 4);
      std::memcpy(&length, &bytes[8], 4);
      std::memcpy(&chunk_length, &bytes[12], 4);
      std::memcpy(&chunk_type, &bytes[16], 4);
      if (version != 2) fail("GLB version " + std::to_string(version) + "; only glTF 2.0 (version 2) is read");
      if (length != bytes.size())
        fail("the GLB header gives a length of " + std::to_string(length) + " bytes, the file has " +
             std::to_string(bytes.size()));
      if (chunk_type != 0x4E4F534Au) fail("the first GLB chunk is not of type JSON");
      if (chunk_length > bytes.size() - 20) fail("the GLB JSON chunk runs past the end of the file");
      json_text = bytes.substr(20, chunk_length);
      *bin_offset = 20 + static_cast<size_t>(chunk_length);
    }
    nlohmann::json j = nlohmann::json::parse(json_text, nullptr, false);
    if (j.is_discarded() || !j.is_object()) return j;  // tinygltf reports these
    check_schema_types(j);
    const auto nodes = j.find("nodes");
    if (nodes == j.end() || !nodes->is_array()) return j;
    for (size_t i = 0; i < nodes->size(); ++i) {
      const nlohmann::json& n = (*nodes)[i];
      if (n.is_object() && n.contains("matrix") &&
          (n.contains("translation") || n.contains("rotation") || n.contains("scale")))
        fail("node " + std::to_string(i) + " has both a matrix and translation, rotation or scale (glTF 2.0, 5.25)");
    }
    return j;
  }

  void read_model() {
    std::string bytes;
    {
      std::error_code ec;
      const auto status = std::filesystem::status(path_, ec);
      if (std::filesystem::is_directory(status)) fail("is a directory, not a glTF file");
      if (std::filesystem::exists(status) && !std::filesystem::is_regular_file(status)) fail("is not a regular file");
      std::ifstream f(path_, std::ios::binary);
      if (!f) fail(std::string("cannot open the file (") + std::strerror(errno) + ")");
      bytes.assign(std::istreambuf_iterator<char>(f), {});
      if (bytes.empty()) fail("the file is empty");
      binary_ = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
      if (!binary_) check_json_start(bytes);
    }
    size_t bin_offset = bytes.size();
    nlohmann::json j = check_raw(bytes, &bin_offset);
    // Compressed files carry JSON tinygltf rejects (gltf_decompress.h): it
    // then reads the prepared JSON from memory.
    JsonFixups fixups;
    std::string prepared;
    if (!j.is_discarded() && j.is_object()) {
      fixups = prepare_json(j);
      if (fixups.changed()) {
        std::string text = j.dump();
        if (binary_) {
          text.append((4 - text.size() % 4) % 4, ' ');
          const std::string rest = bytes.substr(bin_offset);
          const uint32_t chunk = static_cast<uint32_t>(text.size()), total = 20 + chunk + rest.size();
          prepared.assign("glTF", 4);
          for (uint32_t word : {2u, total, chunk, 0x4E4F534Au})
            prepared.append(reinterpret_cast<const char*>(&word), 4);
          prepared += text + rest;
        } else {
          prepared = std::move(text);
        }
      }
    }
    tinygltf::TinyGLTF gltf;
    gltf.SetImageLoader(skip_image, nullptr);
    gltf.SetFsCallbacks(
        {tinygltf::FileExists, tinygltf::ExpandFilePath, read_regular_file, tinygltf::WriteWholeFile, nullptr});
    std::string err, warn;
    bool ok = false;
    try {
      const std::string base_dir = std::filesystem::path(path_).parent_path().string();
      const auto* data = reinterpret_cast<const unsigned char*>(prepared.data());
      if (prepared.empty())
        ok = binary_ ? gltf.LoadBinaryFromFile(&model_, &err, &warn, path_)
                     : gltf.LoadASCIIFromFile(&model_, &err, &warn, path_);
      else
        ok = binary_ ? gltf.LoadBinaryFromMemory(&model_, &err, &warn, data, static_cast<unsigned>(prepared.size()),
                                                 base_dir)
                     : gltf.LoadASCIIFromString(&model_, &err, &warn, prepared.data(),
                                                static_cast<unsigned>(prepared.size()), base_dir);
    } catch (const std::exception& e) {
      fail(std::string("not a readable glTF file: ") + e.what());
    }
    if (!ok) {
      std::string what = err.empty() ? "not a readable glTF file" : err;
      while (!what.empty() && (what.back() == '\n' || what.back() == ' ')) what.pop_back();
      // tinygltf's words for a buffer file that is not there, in ours.
      const std::string missing = "File not found : ";
      if (what.rfind(missing, 0) == 0) {
        const std::string uri = what.substr(missing.size(), what.find('\n') - missing.size());
        const std::filesystem::path dir = std::filesystem::path(path_).parent_path();
        fail("buffer file \"" + uri + "\" does not exist (looked for " + (dir / uri).string() + ")");
      }
      fail(what);
    }
    // Images are never decoded, so a missing image file is no concern of
    // rayfold's (tinygltf reports one; a missing buffer is an error).
    std::istringstream lines(warn);
    for (std::string line; std::getline(lines, line);) {
      if (line.empty() || line.rfind("File not found : ", 0) == 0 ||
          line.find("Failed to load external 'uri' for image[") != std::string::npos)
        continue;
      this->warn(line);
    }
    restore_fixups(model_, fixups);
    fallback_buffers_ = fixups.fallback_buffers;
    decode_meshopt_views(model_, fixups, path_);
    decoded_ = decode_draco_primitives(model_, path_);
  }

  void check_extensions() const {
    std::string unsupported;
    for (const std::string& ext : model_.extensionsRequired)
      if (!geometry_neutral(ext)) unsupported += (unsupported.empty() ? "" : ", ") + ext;
    if (!unsupported.empty()) fail("requires extensions rayfold does not support: " + unsupported);
  }

  std::vector<int> root_nodes() {
    for (const tinygltf::Scene& sc : model_.scenes) scene_.scene_names.push_back(sc.name);
    if (options_.scene >= 0 && static_cast<size_t>(options_.scene) >= model_.scenes.size())
      fail("scene " + std::to_string(options_.scene) + " does not exist (the file has " +
           std::to_string(model_.scenes.size()) + " scenes)");
    if (!model_.scenes.empty()) {
      const int s = options_.scene >= 0 ? options_.scene : model_.defaultScene >= 0 ? model_.defaultScene : 0;
      if (static_cast<size_t>(s) >= model_.scenes.size()) fail("the default scene index is out of range");
      scene_.scene_index = s;
      return model_.scenes[s].nodes;
    }
    // "scene" names a scene the file must have: --scene 0 on such a file is
    // an error, so its own default is too.
    if (model_.defaultScene >= 0)
      fail("\"scene\" is " + std::to_string(model_.defaultScene) + " but the file has no scenes");
    // No scene: every node that is nobody's child is a root.
    std::vector<char> is_child(model_.nodes.size(), 0);
    for (const tinygltf::Node& n : model_.nodes)
      for (int c : n.children)
        if (c >= 0 && static_cast<size_t>(c) < model_.nodes.size()) is_child[c] = 1;
    std::vector<int> roots;
    for (size_t i = 0; i < model_.nodes.size(); ++i)
      if (!is_child[i]) roots.push_back(static_cast<int>(i));
    return roots;
  }

  Xform local_transform(int ni) {
    const tinygltf::Node& n = model_.nodes[ni];
    const std::string where = "node " + std::to_string(ni);
    auto finite = [&](const std::vector<double>& v, const char* what) {
      for (double x : v)
        if (!std::isfinite(x)) fail(where + " has a non-finite " + what);
    };
    if (!n.matrix.empty()) {
      if (n.matrix.size() != 16) fail(where + " has a matrix with " + std::to_string(n.matrix.size()) + " values");
      finite(n.matrix, "matrix");
      Xform m = glm::make_mat4(n.matrix.data());
      if (m[0][3] != 0.0 || m[1][3] != 0.0 || m[2][3] != 0.0 || m[3][3] != 1.0)
        fail(where + " has a matrix that is not affine (its last row must be 0 0 0 1)");
      return m;
    }
    for (const auto* v : {&n.translation, &n.scale})
      if (!v->empty() && v->size() != 3) fail(where + " has a translation or scale without 3 values");
    if (!n.rotation.empty() && n.rotation.size() != 4) fail(where + " has a rotation without 4 values");
    finite(n.translation, "translation");
    finite(n.rotation, "rotation");
    finite(n.scale, "scale");
    return trs(n.translation.empty() ? nullptr : n.translation.data(), n.rotation.empty() ? nullptr : n.rotation.data(),
               n.scale.empty() ? nullptr : n.scale.data(), where);
  }

  // T * R * S (glTF 2.0, 3.5.3); a missing part is the identity. A rotation
  // quaternion (x, y, z, w) that is not unit length is normalised, with a
  // warning.
  Xform trs(const double* t, const double* r, const double* s, const std::string& where) {
    Xform m(1.0);
    if (t) m[3] = glm::dvec4(t[0], t[1], t[2], 1.0);
    if (r) {
      glm::dquat q(r[3], r[0], r[1], r[2]);
      const double len = glm::length(q);
      if (!(len > 0.0)) fail(where + " has a zero rotation quaternion");
      if (std::fabs(len - 1.0) > 1e-3) warn(where + " has a rotation quaternion that is not unit length; normalised");
      m = m * Xform(glm::mat4_cast(q / len));
    }
    if (s) m = glm::scale(m, glm::dvec3(s[0], s[1], s[2]));
    return m;
  }

  // EXT_mesh_gpu_instancing: the node's mesh drawn once per element of its
  // TRANSLATION, ROTATION and SCALE accessors, each transform applied before
  // the node's own. Empty when the node does not use it.
  std::vector<Xform> gpu_instances(int ni) {
    const auto ext = model_.nodes[ni].extensions.find("EXT_mesh_gpu_instancing");
    if (ext == model_.nodes[ni].extensions.end()) return {};
    const std::string where = "node " + std::to_string(ni) + " (EXT_mesh_gpu_instancing)";
    if (!ext->second.IsObject() || !ext->second.Has("attributes") || !ext->second.Get("attributes").IsObject())
      fail(where + " has none of TRANSLATION, ROTATION and SCALE");
    const tinygltf::Value& attrs = ext->second.Get("attributes");
    std::vector<double> parts[3];
    const char* names[3] = {"TRANSLATION", "ROTATION", "SCALE"};
    const int components[3] = {3, 4, 3};
    size_t count = 0;
    bool any = false;
    for (int k = 0; k < 3; ++k) {
      if (!attrs.Has(names[k])) continue;
      if (!attrs.Get(names[k]).IsInt()) fail(where + ": " + names[k] + " must be an accessor index");
      const int ai = attrs.Get(names[k]).GetNumberAsInt();
      const std::string what = where + " " + names[k];
      if (ai >= 0 && static_cast<size_t>(ai) < model_.accessors.size()) {
        const tinygltf::Accessor& a = model_.accessors[ai];
        if (a.type != (k == 1 ? TINYGLTF_TYPE_VEC4 : TINYGLTF_TYPE_VEC3))
          fail(what + " must be " + (k == 1 ? "VEC4" : "VEC3"));
        const bool quantized_rotation =
            k == 1 && a.normalized &&
            (a.componentType == TINYGLTF_COMPONENT_TYPE_BYTE || a.componentType == TINYGLTF_COMPONENT_TYPE_SHORT);
        if (a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT && !quantized_rotation)
          fail(what + " must be FLOAT" + (k == 1 ? " or normalized byte or short" : ""));
      }
      parts[k] = read_elements(ai, what, components[k], false);
      for (double v : parts[k])
        if (!std::isfinite(v)) fail(what + " holds a non-finite value");
      const size_t n = parts[k].size() / components[k];
      if (any && n != count)
        fail(where + ": its attributes hold different numbers of instances (" + std::to_string(count) + " and " +
             std::to_string(n) + ")");
      count = n;
      any = true;
    }
    if (!any) fail(where + " has none of TRANSLATION, ROTATION and SCALE");
    std::vector<Xform> out(count);
    for (size_t i = 0; i < count; ++i)
      out[i] = trs(parts[0].empty() ? nullptr : &parts[0][3 * i], parts[1].empty() ? nullptr : &parts[1][4 * i],
                   parts[2].empty() ? nullptr : &parts[2][3 * i], where + " instance " + std::to_string(i));
    return out;
  }

  // The node's name, or "node N" for an unnamed node (as the docs promise).
  std::string node_name(int ni) const {
    const std::string& name = model_.nodes[ni].name;
    return name.empty() ? "node " + std::to_string(ni) : name;
  }

  void add_camera(int ni, const Xform& world_from_node) {
    const int ci = model_.nodes[ni].camera;
    if (static_cast<size_t>(ci) >= model_.cameras.size())
      fail("node " + std::to_string(ni) + " refers to camera " + std::to_string(ci) + ", which does not exist");
    const tinygltf::Camera& c = model_.cameras[ci];
    Scene::FileCamera fc;
    fc.name = node_name(ni);
    fc.node = ni;
    fc.perspective = c.type == "perspective";
    fc.spec.eye = transform_point(world_from_node, glm::dvec3(0.0));
    fc.spec.look_at = transform_point(world_from_node, glm::dvec3(0.0, 0.0, -1.0));
    fc.spec.up = glm::dvec3(world_from_node * glm::dvec4(0.0, 1.0, 0.0, 0.0));
    if (fc.perspective) {
      fc.spec.vfov_degrees = c.perspective.yfov * 180.0 / M_PI;
      if (!(fc.spec.vfov_degrees > 0.0 && fc.spec.vfov_degrees < 180.0)) {
        warn("camera " + std::to_string(ci) + " has a vertical field of view outside (0, 180) degrees; ignored");
        return;
      }
    } else if (c.type == "orthographic") {
      // ymag: half the view's height in world units (square pixels set the
      // width from the image's; xmag is not needed).
      fc.spec.orthographic = true;
      fc.spec.ymag = std::fabs(c.orthographic.ymag);
      if (!(fc.spec.ymag > 0.0 && std::isfinite(fc.spec.ymag))) {
        warn("camera " + std::to_string(ci) + " has an orthographic ymag that is not positive; ignored");
        return;
      }
    } else {
      warn("camera " + std::to_string(ci) + " has the unknown type '" + c.type + "'; ignored");
      return;
    }
    scene_.cameras.push_back(fc);
  }

  // The camera the scene is rendered with: the one asked for, else the
  // file's first (as glTF viewers start with).
  void choose_camera() {
    const int asked = options_.camera;
    if (asked >= 0) {
      if (static_cast<size_t>(asked) >= scene_.cameras.size())
        fail("camera " + std::to_string(asked) + " does not exist (the scene shows " +
             std::to_string(scene_.cameras.size()) + " cameras)");
      scene_.camera = scene_.cameras[asked].spec;
      return;
    }
    if (!scene_.cameras.empty()) scene_.camera = scene_.cameras.front().spec;
  }

  void add_instance(int ni, const Xform& world_from_node) {
    const int mi = model_.nodes[ni].mesh;
    if (static_cast<size_t>(mi) >= model_.meshes.size())
      fail("node " + std::to_string(ni) + " refers to mesh " + std::to_string(mi) + ", which does not exist");
    // Morph weights: the node's override the mesh's; each set of weights is
    // a mesh of its own, and so is each skin a mesh is bound with.
    const std::vector<double>& weights =
        model_.nodes[ni].weights.empty() ? model_.meshes[mi].weights : model_.nodes[ni].weights;
    const int skin = model_.nodes[ni].skin;
    if (skin >= 0 && static_cast<size_t>(skin) >= model_.skins.size())
      fail("node " + std::to_string(ni) + " refers to skin " + std::to_string(skin) + ", which does not exist");
    const MeshKey key{mi, weights, skin};
    auto found = mesh_slot_.find(key);
    if (found == mesh_slot_.end()) found = mesh_slot_.emplace(key, mesh_for(mi, weights, skin)).first;
    const std::vector<Xform> gpu = gpu_instances(ni);
    if (found->second < 0) return;  // a mesh without triangles
    // A skinned mesh's vertices are placed by its joints, in world space;
    // the node's own transform does not apply (glTF 2.0, 3.7.3.3).
    const Xform world_from_object = skin >= 0 ? Xform(1.0) : world_from_node;
    if (linear_determinant(world_from_object) == 0.0)
      warn("node " + std::to_string(ni) + " has a zero scale; it is hidden");
    Instance inst;
    inst.mesh = static_cast<uint32_t>(found->second);
    inst.world_from_object = world_from_object;
    inst.name = node_name(ni);
    inst.node = ni;
    if (gpu.empty()) {
      scene_.instances.push_back(std::move(inst));
      return;
    }
    // One scene instance per GPU instance, consecutive ids, named
    // "<node>[i]".
    for (size_t i = 0; i < gpu.size(); ++i) {
      Instance g = inst;
      g.world_from_object = world_from_object * gpu[i];
      g.name = inst.name + "[" + std::to_string(i) + "]";
      if (linear_determinant(g.world_from_object) == 0.0)
        warn("node " + std::to_string(ni) + " GPU instance " + std::to_string(i) + " has a zero scale; it is hidden");
      scene_.instances.push_back(std::move(g));
    }
  }

  // Morph targets at the default weights (glTF 2.0, 3.7.2.2): the node's,
  // else the mesh's, else 0; summed in double and rounded once.
  void apply_morph_targets(int mi, size_t pi, const std::vector<double>& weights, const std::string& where,
                           std::vector<glm::vec3>& positions) const {
    const tinygltf::Primitive& prim = model_.meshes[mi].primitives[pi];
    if (prim.targets.empty()) return;
    if (!weights.empty() && weights.size() != prim.targets.size())
      fail(where + " has " + std::to_string(prim.targets.size()) + " morph targets but " +
           std::to_string(weights.size()) + " weights");
    std::vector<glm::dvec3> sum(positions.begin(), positions.end());
    bool moved = false;
    for (size_t t = 0; t < prim.targets.size(); ++t) {
      const double w = weights.empty() ? 0.0 : weights[t];
      const auto p = prim.targets[t].find("POSITION");
      if (w == 0.0 || p == prim.targets[t].end()) continue;
      const std::vector<glm::vec3> d =
          read_vec3(p->second, where + ": morph target " + std::to_string(t) + " POSITION");
      if (d.size() != positions.size())
        fail(where + ": morph target " + std::to_string(t) + " has " + std::to_string(d.size()) + " positions for " +
             std::to_string(positions.size()) + " vertices");
      for (size_t i = 0; i < d.size(); ++i) sum[i] += w * glm::dvec3(d[i]);
      moved = true;
    }
    if (moved)
      for (size_t i = 0; i < positions.size(); ++i) positions[i] = glm::vec3(sum[i]);
  }

  // Every animation channel sampled at `time`, written over the node's TRS or
  // weights before the hierarchy is read (glTF 2.0, 3.11). Times outside a
  // sampler's keys hold its first or last value.
  void pose_at(double time) {
    if (!std::isfinite(time)) fail("the animation time must be finite");
    for (size_t ai = 0; ai < model_.animations.size(); ++ai) {
      const tinygltf::Animation& anim = model_.animations[ai];
      for (size_t ci = 0; ci < anim.channels.size(); ++ci) {
        const tinygltf::AnimationChannel& ch = anim.channels[ci];
        const std::string where = "animation " + std::to_string(ai) + " channel " + std::to_string(ci);
        if (ch.target_node < 0) continue;  // a channel of an extension's object
        if (static_cast<size_t>(ch.target_node) >= model_.nodes.size())
          fail(where + " targets node " + std::to_string(ch.target_node) + ", which does not exist");
        if (ch.sampler < 0 || static_cast<size_t>(ch.sampler) >= anim.samplers.size())
          fail(where + " refers to sampler " + std::to_string(ch.sampler) + ", which does not exist");
        tinygltf::Node& node = model_.nodes[ch.target_node];
        const int n = ch.target_path == "translation" || ch.target_path == "scale" ? 3
                      : ch.target_path == "rotation"                               ? 4
                      : ch.target_path == "weights" ? static_cast<int>(weight_count(ch.target_node))
                                                    : -1;
        if (n < 0) fail(where + " animates '" + ch.target_path + "', which is not a node property glTF defines");
        if (n == 0) fail(where + " animates the weights of a node whose mesh has no morph targets");
        if (ch.target_path != "weights" && !node.matrix.empty())
          fail(where + " animates node " + std::to_string(ch.target_node) + ", which has a matrix (glTF 2.0, 3.5.3)");
        const std::vector<double> v = sample(anim.samplers[ch.sampler], n, ch.target_path == "rotation", time, where);
        if (ch.target_path == "translation") node.translation = v;
        if (ch.target_path == "rotation") node.rotation = v;
        if (ch.target_path == "scale") node.scale = v;
        if (ch.target_path == "weights") node.weights = v;
      }
    }
  }

  // Components per element of an accessor's type (VEC3: 3), for values read
  // whole; 0 refused.
  int components(int ai, const std::string& where) const {
    if (ai < 0 || static_cast<size_t>(ai) >= model_.accessors.size())
      fail(where + ": accessor " + std::to_string(ai) + " does not exist");
    const int n = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(model_.accessors[ai].type));
    if (n <= 0) fail(where + ": accessor " + std::to_string(ai) + " has an unknown type");
    return n;
  }

  size_t weight_count(int ni) const {
    const int mi = model_.nodes[ni].mesh;
    if (mi < 0 || static_cast<size_t>(mi) >= model_.meshes.size() || model_.meshes[mi].primitives.empty()) return 0;
    return model_.meshes[mi].primitives[0].targets.size();
  }

  // One sampler's value at `time`: n components per key (3n for a cubic
  // spline: in-tangent, value, out-tangent).
  std::vector<double> sample(const tinygltf::AnimationSampler& s, int n, bool rotation, double time,
                             const std::string& where) const {
    const bool cubic = s.interpolation == "CUBICSPLINE";
    if (!cubic && s.interpolation != "LINEAR" && s.interpolation != "STEP")
      fail(where + " has the unknown interpolation '" + s.interpolation + "'");
    const std::vector<double> keys = read_elements(s.input, where + " input", 1, false);
    if (keys.empty()) fail(where + " has no keyframes");
    for (size_t k = 0; k < keys.size(); ++k)
      if (!std::isfinite(keys[k]) || (k > 0 && !(keys[k] > keys[k - 1])))
        fail(where + ": keyframe times must be finite and strictly increasing (key " + std::to_string(k) + ")");
    const size_t per = static_cast<size_t>(n) * (cubic ? 3 : 1);
    std::vector<double> out = read_elements(s.output, where + " output", components(s.output, where), false);
    if (out.size() != per * keys.size())
      fail(where + " has " + std::to_string(out.size()) + " output values for " + std::to_string(keys.size()) +
           " keyframes of " + std::to_string(per));
    for (double x : out)
      if (!std::isfinite(x)) fail(where + " has a non-finite output value");
    auto value = [&](size_t k, int part) {  // part: 0 in-tangent, 1 value, 2 out-tangent (cubic)
      const size_t base = k * per + (cubic ? static_cast<size_t>(part) * n : 0);
      return std::vector<double>(out.begin() + base, out.begin() + base + n);
    };
    if (time <= keys.front()) return value(0, 1);
    if (time >= keys.back()) return value(keys.size() - 1, 1);
    const size_t k = static_cast<size_t>(std::upper_bound(keys.begin(), keys.end(), time) - keys.begin()) - 1;
    const double dt = keys[k + 1] - keys[k], u = (time - keys[k]) / dt;
    std::vector<double> a = value(k, 1), b = value(k + 1, 1), r(n);
    if (s.interpolation == "STEP") return a;
    if (cubic) {
      const std::vector<double> out_tangent = value(k, 2), in_tangent = value(k + 1, 0);
      const double u2 = u * u, u3 = u2 * u;
      for (int c = 0; c < n; ++c)
        r[c] = (2 * u3 - 3 * u2 + 1) * a[c] + (u3 - 2 * u2 + u) * dt * out_tangent[c] + (-2 * u3 + 3 * u2) * b[c] +
               (u3 - u2) * dt * in_tangent[c];
    } else if (rotation) {
      glm::dquat qa(a[3], a[0], a[1], a[2]), qb(b[3], b[0], b[1], b[2]);
      const glm::dquat q = glm::slerp(glm::normalize(qa), glm::normalize(qb), u);
      r = {q.x, q.y, q.z, q.w};
    } else {
      for (int c = 0; c < n; ++c) r[c] = a[c] + u * (b[c] - a[c]);
    }
    if (rotation) {
      const double len = std::sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2] + r[3] * r[3]);
      if (!(len > 0.0)) fail(where + " interpolates to a zero rotation");
      for (double& x : r) x /= len;
    }
    return r;
  }

  // World transform of any node, whether or not the scene shows it (joints
  // may live outside the scene's hierarchy): its ancestors' transforms times
  // its own, memoised.
  Xform node_world(int ni) {
    if (parent_.empty()) {
      parent_.assign(model_.nodes.size(), -1);
      for (size_t p = 0; p < model_.nodes.size(); ++p)
        for (int c : model_.nodes[p].children)
          if (c >= 0 && static_cast<size_t>(c) < model_.nodes.size()) parent_[c] = static_cast<int>(p);
      world_.resize(model_.nodes.size());
      world_known_.assign(model_.nodes.size(), 0);
    }
    std::vector<int> chain;
    for (int n = ni; n >= 0 && !world_known_[n]; n = parent_[n]) {
      if (chain.size() > model_.nodes.size()) fail("node " + std::to_string(ni) + " has a cycle among its ancestors");
      chain.push_back(n);
    }
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
      const int n = *it;
      world_[n] = (parent_[n] >= 0 ? world_[parent_[n]] : Xform(1.0)) * local_transform(n);
      world_known_[n] = 1;
    }
    return world_[ni];
  }

  // A skin's joint matrices at the default pose: each joint's world
  // transform times its inverse bind matrix (identity when absent).
  std::vector<Xform> joint_matrices(int si) {
    const tinygltf::Skin& sk = model_.skins[si];
    const std::string where = "skin " + std::to_string(si);
    if (sk.joints.empty()) fail(where + " has no joints");
    std::vector<double> ibm;
    if (sk.inverseBindMatrices >= 0) {
      if (static_cast<size_t>(sk.inverseBindMatrices) < model_.accessors.size()) {
        const tinygltf::Accessor& a = model_.accessors[sk.inverseBindMatrices];
        if (a.type != TINYGLTF_TYPE_MAT4 || a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT)
          fail(where + ": inverseBindMatrices must be MAT4 of FLOAT");
      }
      ibm = read_elements(sk.inverseBindMatrices, where + " inverseBindMatrices", 16, false);
      if (ibm.size() != 16 * sk.joints.size())
        fail(where + " has " + std::to_string(ibm.size() / 16) + " inverse bind matrices for " +
             std::to_string(sk.joints.size()) + " joints");
    }
    std::vector<Xform> out;
    for (size_t j = 0; j < sk.joints.size(); ++j) {
      const int jn = sk.joints[j];
      if (jn < 0 || static_cast<size_t>(jn) >= model_.nodes.size())
        fail(where + ": joint " + std::to_string(j) + " is node " + std::to_string(jn) + ", which does not exist");
      Xform inverse_bind(1.0);
      if (!ibm.empty()) {
        for (int k = 0; k < 16; ++k)
          if (!std::isfinite(ibm[16 * j + k]))
            fail(where + ": inverse bind matrix " + std::to_string(j) + " is not finite");
        inverse_bind = glm::make_mat4(&ibm[16 * j]);
      }
      out.push_back(node_world(jn) * inverse_bind);
    }
    return out;
  }

  // Linear blend skinning (glTF 2.0, 3.7.3): each vertex moved by the
  // weighted sum of its joints' matrices, from every JOINTS_n / WEIGHTS_n
  // set; summed in double and rounded once.
  void apply_skin(const tinygltf::Primitive& prim, const std::vector<Xform>& joints, const std::string& where,
                  std::vector<glm::vec3>& positions) const {
    std::vector<glm::dvec3> sum(positions.size(), glm::dvec3(0.0));
    std::vector<double> total(positions.size(), 0.0);
    int sets = 0;
    for (int set = 0;; ++set) {
      const auto j = prim.attributes.find("JOINTS_" + std::to_string(set));
      const auto w = prim.attributes.find("WEIGHTS_" + std::to_string(set));
      if (j == prim.attributes.end() && w == prim.attributes.end()) break;
      if (j == prim.attributes.end() || w == prim.attributes.end())
        fail(where + ": JOINTS_" + std::to_string(set) + " and WEIGHTS_" + std::to_string(set) + " come in pairs");
      const std::vector<double> ji = read_elements(j->second, where + ": JOINTS_" + std::to_string(set), 4, false);
      const std::vector<double> wi = read_elements(w->second, where + ": WEIGHTS_" + std::to_string(set), 4, false);
      if (ji.size() != 4 * positions.size() || wi.size() != 4 * positions.size())
        fail(where + ": JOINTS_" + std::to_string(set) + " or WEIGHTS_" + std::to_string(set) +
             " does not have one element per vertex");
      for (size_t v = 0; v < positions.size(); ++v)
        for (int k = 0; k < 4; ++k) {
          const double weight = wi[4 * v + k];
          if (weight == 0.0) continue;
          if (!(weight >= 0.0) || !std::isfinite(weight))
            fail(where + ": vertex " + std::to_string(v) + " has a weight that is not a finite non-negative number");
          const double joint = ji[4 * v + k];
          if (joint < 0.0 || joint >= static_cast<double>(joints.size()) || joint != std::floor(joint))
            fail(where + ": vertex " + std::to_string(v) + " refers to joint " +
                 std::to_string(static_cast<long long>(joint)) + " of " + std::to_string(joints.size()));
          sum[v] += weight * glm::dvec3(joints[static_cast<size_t>(joint)] * glm::dvec4(glm::dvec3(positions[v]), 1.0));
          total[v] += weight;
        }
      ++sets;
    }
    if (sets == 0) fail(where + " is bound to a skin but has no JOINTS_0 and WEIGHTS_0");
    for (size_t v = 0; v < positions.size(); ++v) {
      if (!(total[v] > 0.0)) fail(where + ": vertex " + std::to_string(v) + " has no joint weight");
      // Weights should sum to 1; normalising keeps a file that rounds them
      // (as 8-bit weights do) from shrinking the mesh.
      positions[v] = glm::vec3(sum[v] / total[v]);
    }
  }

  // Converts a glTF mesh (all its triangle primitives) into one Mesh; returns
  // its index in scene_.meshes, or -1 when it has no triangles.
  // This build's scene mesh. In an animated file a mesh without skin and
  // morph weights does not depend on the pose: it is converted once and
  // copied into later poses (GltfFile::scene_at per frame). Skinned meshes
  // follow their joints and weighted ones their (maybe animated) weights:
  // converted every time, so that no cache grows frame by frame.
  int mesh_for(int mi, const std::vector<double>& weights, int skin) {
    if (!cache_meshes_ || skin >= 0 || !weights.empty()) return convert_mesh(mi, weights, skin);
    const MeshKey key{mi, weights, skin};
    const auto cached = converted_.find(key);
    if (cached == converted_.end()) {
      const int slot = convert_mesh(mi, weights, skin);
      converted_.emplace(key, slot < 0 ? std::optional<Mesh>() : std::optional<Mesh>(scene_.meshes[slot]));
      return slot;
    }
    if (!cached->second) return -1;
    scene_.meshes.push_back(*cached->second);
    return static_cast<int>(scene_.meshes.size()) - 1;
  }

  int convert_mesh(int mi, const std::vector<double>& weights, int skin) {
    const std::vector<Xform> joints = skin >= 0 ? joint_matrices(skin) : std::vector<Xform>{};
    const tinygltf::Mesh& gm = model_.meshes[mi];
    Mesh mesh;
    mesh.name = gm.name;
    for (size_t pi = 0; pi < gm.primitives.size(); ++pi) {
      const tinygltf::Primitive& prim = gm.primitives[pi];
      const std::string where = "mesh " + std::to_string(mi) + " primitive " + std::to_string(pi);
      const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
      if (mode == TINYGLTF_MODE_POINTS || mode == TINYGLTF_MODE_LINE || mode == TINYGLTF_MODE_LINE_LOOP ||
          mode == TINYGLTF_MODE_LINE_STRIP) {
        warn(where + " draws points or lines; skipped");
        continue;
      }
      if (mode != TINYGLTF_MODE_TRIANGLES && mode != TINYGLTF_MODE_TRIANGLE_STRIP && mode != TINYGLTF_MODE_TRIANGLE_FAN)
        fail(where + " has an unknown primitive mode " + std::to_string(mode));
      const auto pos = prim.attributes.find("POSITION");
      if (pos == prim.attributes.end()) fail(where + " has no POSITION attribute");
      const uint32_t base = static_cast<uint32_t>(mesh.positions.size());
      std::vector<glm::vec3> positions = read_vec3(pos->second, where + ": POSITION");
      apply_morph_targets(mi, pi, weights, where, positions);
      if (skin >= 0) apply_skin(prim, joints, where, positions);
      mesh.positions.insert(mesh.positions.end(), positions.begin(), positions.end());
      const uint32_t vertex_count = static_cast<uint32_t>(positions.size());
      std::vector<uint32_t> seq;
      if (prim.indices >= 0) {
        read_indices(prim.indices, where, vertex_count, seq);
      } else {
        seq.resize(vertex_count);
        for (uint32_t i = 0; i < vertex_count; ++i) seq[i] = i;
      }
      size_t dropped = 0;
      append_triangles(mode, seq, base, mesh.indices, &dropped);
      if (dropped)
        warn(where + " has " + std::to_string(seq.size()) + " triangle vertices, not a multiple of 3; the last " +
             std::to_string(dropped) + " are ignored");
    }
    if (mesh.indices.empty()) {
      warn("mesh " + std::to_string(mi) + (gm.name.empty() ? "" : " (" + gm.name + ")") + " has no triangles");
      return -1;
    }
    scene_.meshes.push_back(std::move(mesh));
    return static_cast<int>(scene_.meshes.size()) - 1;
  }

  static void append_triangles(int mode, const std::vector<uint32_t>& seq, uint32_t base, std::vector<uint32_t>& out,
                               size_t* dropped) {
    auto tri = [&](uint32_t a, uint32_t b, uint32_t c) {
      out.push_back(base + seq[a]);
      out.push_back(base + seq[b]);
      out.push_back(base + seq[c]);
    };
    const size_t n = seq.size();
    if (mode == TINYGLTF_MODE_TRIANGLES) {
      for (size_t i = 0; i + 2 < n; i += 3) tri(i, i + 1, i + 2);
      if (n % 3 != 0 && dropped) *dropped = n % 3;
    } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
      // glTF 2.0 spec 3.7.2.1: triangle i is (i, i + 1 + i % 2, i + 2 - i % 2).
      for (size_t i = 0; i + 2 < n; ++i) tri(i, i + 1 + i % 2, i + 2 - i % 2);
    } else {
      // Fan: triangle i is (i + 1, i + 2, 0).
      for (size_t i = 0; i + 2 < n; ++i) tri(i + 1, i + 2, 0);
    }
  }

  bool uses_extension(const std::string& name) const {
    for (const std::string& e : model_.extensionsUsed)
      if (e == name) return true;
    return false;
  }

  static size_t component_bytes(int type) {
    switch (type) {
      case TINYGLTF_COMPONENT_TYPE_BYTE:
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
      case TINYGLTF_COMPONENT_TYPE_SHORT:
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
      case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
      default: return 0;
    }
  }

  // One component as glTF reads it (2.0, 3.11): FLOAT as stored, a
  // normalized integer mapped to [0, 1] or [-1, 1], any other integer as its
  // value.
  static double component(const unsigned char* p, int type, bool normalized) {
    switch (type) {
      case TINYGLTF_COMPONENT_TYPE_BYTE: {
        const double v = static_cast<int8_t>(p[0]);
        return normalized ? std::max(v / 127.0, -1.0) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return normalized ? p[0] / 255.0 : p[0];
      case TINYGLTF_COMPONENT_TYPE_SHORT: {
        int16_t v;
        std::memcpy(&v, p, 2);
        return normalized ? std::max(v / 32767.0, -1.0) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t v;
        std::memcpy(&v, p, 2);
        return normalized ? v / 65535.0 : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        uint32_t v;
        std::memcpy(&v, p, 4);
        return v;
      }
      default: {
        float v;
        std::memcpy(&v, p, 4);
        return v;
      }
    }
  }

  // `count` elements of `element_bytes` from view vi at `offset` with the
  // view's stride (or tightly packed): the bytes of element 0 and the
  // stride, after checking that the last element ends inside the view.
  const unsigned char* view_data(int vi, size_t offset, size_t count, size_t element_bytes, size_t align, bool is_index,
                                 const std::string& acc, size_t* stride) const {
    if (vi < 0 || static_cast<size_t>(vi) >= model_.bufferViews.size())
      fail(acc + " refers to a buffer view that does not exist");
    const tinygltf::BufferView& v = model_.bufferViews[vi];
    if (std::find(fallback_buffers_.begin(), fallback_buffers_.end(), v.buffer) != fallback_buffers_.end())
      fail(acc + ": its buffer view reads a meshopt fallback buffer, which holds no data");
    if (v.buffer < 0 || static_cast<size_t>(v.buffer) >= model_.buffers.size())
      fail(acc + ": its buffer view refers to a buffer that does not exist");
    const std::vector<unsigned char>& data = model_.buffers[v.buffer].data;
    if (v.byteOffset > data.size() || v.byteLength > data.size() - v.byteOffset)
      fail(acc + ": its buffer view (offset " + std::to_string(v.byteOffset) + ", length " +
           std::to_string(v.byteLength) + ") runs past its buffer of " + std::to_string(data.size()) + " bytes");
    // glTF 2.0, 3.6.2.4 and 5.11: strides are 4..252 and a multiple of 4;
    // index views have none; accessors are aligned to their component size.
    if (v.byteStride != 0 && (v.byteStride < 4 || v.byteStride > 252 || v.byteStride % 4 != 0))
      fail(acc + ": its buffer view's byteStride " + std::to_string(v.byteStride) +
           " is not a multiple of 4 between 4 and 252");
    if (is_index && v.byteStride != 0) fail(acc + " holds indices but its buffer view defines a byteStride");
    if ((v.byteOffset + offset) % align != 0)
      fail(acc + " is not aligned to its " + std::to_string(align) + "-byte components");
    *stride = v.byteStride ? v.byteStride : element_bytes;
    if (*stride < element_bytes) fail(acc + " has a byte stride smaller than its element");
    if (count == 0) return nullptr;
    // Written so that no product can overflow: the last element must end
    // inside the view.
    if (offset > v.byteLength || element_bytes > v.byteLength - offset ||
        (count - 1) > (v.byteLength - offset - element_bytes) / *stride)
      fail(acc + " (" + std::to_string(count) + " elements from offset " + std::to_string(offset) +
           ") runs past its buffer view of " + std::to_string(v.byteLength) + " bytes");
    return data.data() + v.byteOffset + offset;
  }

  // An accessor's elements, `components` per element, as glTF reads them
  // (component()), with a sparse accessor's substitutions applied over its
  // base values (zeros without a buffer view).
  std::vector<double> read_elements(int ai, const std::string& what, int components, bool is_index) const {
    const std::string acc = what + " accessor " + std::to_string(ai);
    if (ai < 0 || static_cast<size_t>(ai) >= model_.accessors.size()) fail(acc + " does not exist");
    const tinygltf::Accessor& a = model_.accessors[ai];
    const size_t cb = component_bytes(a.componentType);
    if (cb == 0) fail(acc + " has an unknown component type " + std::to_string(a.componentType));
    const size_t element = cb * static_cast<size_t>(components);
    const auto decoded = decoded_.find(ai);
    if (decoded != decoded_.end()) {
      if (decoded->second.size() != a.count * static_cast<size_t>(components))
        fail(acc + " has " + std::to_string(components) + " components per element; its Draco attribute has " +
             std::to_string(decoded->second.size() / std::max<size_t>(a.count, 1)));
      return decoded->second;
    }
    std::vector<double> out;
    if (a.count > (size_t(1) << 31)) fail(acc + " has " + std::to_string(a.count) + " elements, too many");
    out.assign(a.count * static_cast<size_t>(components), 0.0);
    auto read = [&](const unsigned char* p, size_t stride, size_t n, auto at) {
      for (size_t i = 0; i < n; ++i)
        for (int c = 0; c < components; ++c)
          out[at(i) * components + c] = component(p + i * stride + c * cb, a.componentType, a.normalized);
    };
    if (a.bufferView >= 0 || !a.sparse.isSparse) {
      size_t stride = 0;
      const unsigned char* p = view_data(a.bufferView, a.byteOffset, a.count, element, cb, is_index, acc, &stride);
      read(p, stride, a.count, [](size_t i) { return i; });
    }
    if (a.sparse.isSparse) {
      const size_t n = static_cast<size_t>(std::max(a.sparse.count, 0));
      if (a.sparse.count < 1 || n > a.count)
        fail(acc + " is sparse with " + std::to_string(a.sparse.count) + " substitutions for " +
             std::to_string(a.count) + " elements");
      const int it = a.sparse.indices.componentType;
      if (it != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && it != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
          it != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
        fail(acc + ": sparse indices must be unsigned byte, short or int");
      size_t istride = 0, vstride = 0;
      const unsigned char* ip =
          view_data(a.sparse.indices.bufferView, a.sparse.indices.byteOffset, n, component_bytes(it),
                    component_bytes(it), true, acc + " (sparse indices)", &istride);
      const unsigned char* vp = view_data(a.sparse.values.bufferView, a.sparse.values.byteOffset, n, element, cb, false,
                                          acc + " (sparse values)", &vstride);
      std::vector<size_t> targets(n);
      for (size_t i = 0; i < n; ++i) {
        const double t = component(ip + i * istride, it, false);
        if (t >= static_cast<double>(a.count))
          fail(acc + ": sparse index " + std::to_string(i) + " is " + std::to_string(static_cast<uint64_t>(t)) +
               ", past its " + std::to_string(a.count) + " elements");
        if (i > 0 && t <= static_cast<double>(targets[i - 1]))
          fail(acc + ": sparse indices must strictly increase (index " + std::to_string(i) + ")");
        targets[i] = static_cast<size_t>(t);
      }
      read(vp, vstride, n, [&](size_t i) { return targets[i]; });
    }
    return out;
  }

  // Positions (and morph target displacements): VEC3 of FLOAT, or of
  // (normalized) integers as KHR_mesh_quantization allows.
  std::vector<glm::vec3> read_vec3(int ai, const std::string& what) const {
    if (ai >= 0 && static_cast<size_t>(ai) < model_.accessors.size()) {
      const tinygltf::Accessor& a = model_.accessors[ai];
      if (a.type != TINYGLTF_TYPE_VEC3) fail(what + " accessor " + std::to_string(ai) + " must be VEC3");
      if (a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
        fail(what + " accessor " + std::to_string(ai) + " must be FLOAT or (normalized) byte or short");
      if (a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT && !uses_extension("KHR_mesh_quantization"))
        fail(what + " accessor " + std::to_string(ai) +
             " holds integers, which glTF 2.0 allows only with KHR_mesh_quantization in extensionsUsed");
    }
    const std::vector<double> e = read_elements(ai, what, 3, false);
    std::vector<glm::vec3> out(e.size() / 3);
    for (size_t i = 0; i < out.size(); ++i) {
      out[i] =
          glm::vec3(static_cast<float>(e[3 * i]), static_cast<float>(e[3 * i + 1]), static_cast<float>(e[3 * i + 2]));
      if (!std::isfinite(out[i].x) || !std::isfinite(out[i].y) || !std::isfinite(out[i].z))
        fail(what + " " + std::to_string(i) + " is not finite");
    }
    return out;
  }

  void read_indices(int ai, const std::string& where, uint32_t vertex_count, std::vector<uint32_t>& out) const {
    if (ai < 0 || static_cast<size_t>(ai) >= model_.accessors.size())
      fail(where + ": index accessor " + std::to_string(ai) + " does not exist");
    const tinygltf::Accessor& a = model_.accessors[ai];
    if (a.type != TINYGLTF_TYPE_SCALAR) fail(where + ": indices must be SCALAR");
    if (a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
        a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
      fail(where + ": indices must be unsigned byte, short or int");
    const std::vector<double> e = read_elements(ai, where + ": index", 1, true);
    out.resize(e.size());
    for (size_t i = 0; i < e.size(); ++i) {
      if (e[i] >= vertex_count)
        fail(where + ": index " + std::to_string(i) + " is " + std::to_string(static_cast<uint64_t>(e[i])) +
             ", past the " + std::to_string(vertex_count) + " vertices");
      out[i] = static_cast<uint32_t>(e[i]);
    }
  }

  struct Warning {
    std::string kind, first;
    size_t more;
  };
  std::string path_;
  std::vector<std::string>* warnings_;
  LoadOptions options_;
  std::vector<Warning> pending_;
  bool binary_ = false;
  tinygltf::Model model_;
  std::vector<int> fallback_buffers_;           // meshopt fallback buffers: no data to read
  std::map<int, std::vector<double>> decoded_;  // accessors decoded from Draco primitives
  Scene scene_;
  std::vector<tinygltf::Node> rest_nodes_;  // the file's nodes, before any pose
  struct MeshKey {
    int mesh;
    std::vector<double> weights;
    int skin;
    bool operator<(const MeshKey& o) const {
      return std::tie(mesh, weights, skin) < std::tie(o.mesh, o.weights, o.skin);
    }
  };
  std::map<MeshKey, int> mesh_slot_;                  // glTF mesh, morph weights and skin -> scene mesh (or -1)
  bool cache_meshes_ = false;                         // animated: poses reuse unskinned meshes (mesh_for)
  std::map<MeshKey, std::optional<Mesh>> converted_;  // static meshes of earlier poses; none: no triangles
  std::vector<int> parent_;
  std::vector<Xform> world_;
  std::vector<char> world_known_;
};

}  // namespace

struct GltfFile::Impl {
  std::vector<std::string> warnings;
  Loader loader;
  double end = NAN;
  Impl(const std::string& path, const LoadOptions& options) : loader(path, &warnings, options) {}
};

GltfFile::GltfFile(const std::string& path, const LoadOptions& options)
    : impl_(std::make_unique<Impl>(path, options)), path_(path) {
  impl_->loader.open();
  impl_->end = impl_->loader.animation_end();
  impl_->loader.cache_meshes(!std::isnan(impl_->end));
}

GltfFile::~GltfFile() = default;

Scene GltfFile::scene_at(double time) {
  Scene scene = impl_->loader.build(time);
  check_world_range(scene, path_);
  return scene;
}

bool GltfFile::animated() const { return !std::isnan(impl_->end); }
double GltfFile::animation_end() const { return std::isnan(impl_->end) ? 0.0 : impl_->end; }
const std::vector<std::string>& GltfFile::warnings() const { return impl_->warnings; }

Scene load_gltf(const std::string& path, std::vector<std::string>* warnings, const LoadOptions& options) {
  GltfFile file(path, options);
  Scene scene = file.scene_at(options.time);
  if (warnings) warnings->insert(warnings->end(), file.warnings().begin(), file.warnings().end());
  return scene;
}

bool apply_pose(Scene& scene, Scene&& posed, std::vector<uint32_t>* moved) {
  if (!same_geometry(scene, posed)) {
    scene = std::move(posed);
    return true;
  }
  for (size_t i = 0; i < scene.instances.size(); ++i)
    if (posed.instances[i].world_from_object != scene.instances[i].world_from_object) {
      scene.instances[i].world_from_object = posed.instances[i].world_from_object;
      moved->push_back(static_cast<uint32_t>(i));
    }
  return false;
}

bool same_geometry(const Scene& a, const Scene& b) {
  if (a.meshes.size() != b.meshes.size() || a.instances.size() != b.instances.size()) return false;
  for (size_t i = 0; i < a.instances.size(); ++i)
    if (a.instances[i].mesh != b.instances[i].mesh) return false;
  for (size_t m = 0; m < a.meshes.size(); ++m)
    if (a.meshes[m].positions != b.meshes[m].positions || a.meshes[m].indices != b.meshes[m].indices) return false;
  return true;
}

}  // namespace rayfold::core
