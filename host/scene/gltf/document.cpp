// The file itself: JSON or GLB, the checks tinygltf does not make (schema
// types, GLB header, matrix with TRS), buffers, and required extensions.
#include "scene/gltf/loader.h"

#include <climits>
#include <future>
#include <memory>
#include <system_error>

#include "scene/scene_file_signature.h"
#include "util/parallel.h"

namespace rayfold::core::gltf {

std::atomic<size_t> Loader::side_by_side_reads_{0};

namespace {

// The JSON that makes tinygltf's parse worth a thread of its own beside
// the checks' (Loader::read_model).
constexpr size_t kSideBySideJson = size_t{512} << 10;

// The size of a file's JSON: the whole file, or a GLB's first chunk as its
// header gives it (the checks reject a header that is wrong).
size_t json_bytes(std::string_view file) {
  if (file.size() < 20 || std::memcmp(file.data(), "glTF", 4) != 0) return file.size();
  uint32_t chunk_length;
  std::memcpy(&chunk_length, &file[12], 4);
  return chunk_length;
}

// Hit info needs no pixels: images are decoded only when a render asks for
// a material channel (materials.cpp), from their buffer view or file then;
// only a data: URI's bytes, which tinygltf keeps nowhere else, are kept
// here, encoded.
bool skip_image(tinygltf::Image* image, const int, std::string*, std::string*, int, int, const unsigned char* bytes,
                int size, void*) {
  if (image->bufferView < 0 && image->uri.empty() && bytes && size > 0) {
    image->image.assign(bytes, bytes + size);
    image->as_is = true;
  }
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

}  // namespace

void Loader::check_json_start(std::string_view bytes) const {
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

void Loader::check_schema_types(const nlohmann::json& j) const {
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
  each("scenes", [&](const json& o, const std::string& p) { check(o, p, {{"nodes", kIntArray}, {"name", kString}}); });
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
  each("buffers", [&](const json& o, const std::string& p) { check(o, p, {{"uri", kString}, {"byteLength", kInt}}); });
  each("cameras", [&](const json& o, const std::string& p) {
    check(o, p, {{"type", kString}, {"perspective", kObject}, {"orthographic", kObject}});
    const auto persp = o.find("perspective");
    if (persp != o.end()) check(*persp, p + ".perspective", {{"yfov", kNumber}, {"aspectRatio", kNumber}});
  });
}

nlohmann::json Loader::check_raw(std::string_view bytes, size_t* bin_offset) const {
  std::string_view json_text = bytes;
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
  nlohmann::json j = nlohmann::json::parse(json_text.begin(), json_text.end(), nullptr, false);
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

void Loader::read_model() {
  // The file's bytes, read once into memory that is not cleared first: a
  // std::string zeroed Lost Empire's 17 MB before the read wrote them. From
  // the heap, which keeps a large block for the next load without faults
  // (2 MiB pages, util/large_pages.h, were refused often enough here that
  // a second load took 20 ms rather than 14).
  std::unique_ptr<char[]> file;
  std::string_view bytes;
  {
    std::error_code ec;
    const auto status = std::filesystem::status(path_, ec);
    if (std::filesystem::is_directory(status)) fail("is a directory, not a glTF file");
    if (std::filesystem::exists(status) && !std::filesystem::is_regular_file(status)) fail("is not a regular file");
    std::ifstream f(path_, std::ios::binary | std::ios::ate);
    if (!f) fail(std::string("cannot open the file (") + std::strerror(errno) + ")");
    // Read whole, once: tinygltf parses these bytes, so the file is not read
    // a second time (a character-wise read and tinygltf's own took 40% of
    // loading the dragon's 16 MB).
    const std::streamoff size = f.tellg();
    f.seekg(0);
    if (size > 0) {
      file.reset(new char[static_cast<size_t>(size)]);  // default-initialised: not cleared
      if (!f.read(file.get(), size)) fail(std::string("cannot read the file (") + std::strerror(errno) + ")");
      bytes = std::string_view(file.get(), static_cast<size_t>(size));
    }
    if (bytes.empty()) fail("the file is empty");
    if (is_scene_file(bytes.data(), bytes.size()))
      fail("is a rayfold scene file (Scene.save), not glTF: rayfold.Scene, Scene::load and rayfold-batch read it");
    binary_ = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
    if (!binary_) check_json_start(bytes);
  }
  // tinygltf's parse of the file and the schema checks' parse of its JSON
  // (check_raw), side by side where a second thread is allowed and the JSON
  // is large: the car's 1 MB of JSON took 21 ms of checks before
  // tinygltf's 42 (its load 75 ms alone, 50 side by side). Small JSON stays
  // on one thread: its checks take a millisecond or two, and a thread
  // started while `rayfold render` loads the OpenCL drivers beside the
  // scene waited longer than that (Sponza's load 9 ms, 26 with a thread).
  // Compressed files (gltf_decompress.h) carry JSON tinygltf rejects: it
  // then reads the prepared JSON from memory, after the checks, and its
  // first parse is dropped. A check's error is the one reported, as before.
  struct Parsed {
    tinygltf::Model model;
    std::string err, warn;
    bool ok = false;
  };
  auto parse = [this](std::string_view text) {
    Parsed p;
    tinygltf::TinyGLTF gltf;
    gltf.SetImageLoader(skip_image, nullptr);
    gltf.SetFsCallbacks(
        {tinygltf::FileExists, tinygltf::ExpandFilePath, read_regular_file, tinygltf::WriteWholeFile, nullptr});
    try {
      const std::string base_dir = std::filesystem::path(path_).parent_path().string();
      if (text.size() > UINT_MAX) fail("is larger than 4 GiB, which glTF's loader cannot read");
      const auto* data = reinterpret_cast<const unsigned char*>(text.data());
      p.ok = binary_ ? gltf.LoadBinaryFromMemory(&p.model, &p.err, &p.warn, data, static_cast<unsigned>(text.size()),
                                                 base_dir)
                     : gltf.LoadASCIIFromString(&p.model, &p.err, &p.warn, text.data(),
                                                static_cast<unsigned>(text.size()), base_dir);
    } catch (const InputError&) {
      throw;
    } catch (const std::exception& e) {
      fail(std::string("not a readable glTF file: ") + e.what());
    }
    return p;
  };
  std::future<Parsed> early;  // its destructor waits for the parse, whatever happens here
  if (resolve_threads(options_.threads) > 1 && json_bytes(bytes) >= kSideBySideJson) {
    try {
      early = std::async(std::launch::async, parse, bytes);
      side_by_side_reads_++;
    } catch (const std::system_error&) {  // no thread to be had (a limit on them): tinygltf parses after the checks
    }
  }
  size_t bin_offset = bytes.size();
  nlohmann::json j = check_raw(bytes, &bin_offset);
  JsonFixups fixups;
  std::string prepared;
  if (!j.is_discarded() && j.is_object()) {
    fixups = prepare_json(j);
    if (fixups.changed()) {
      std::string text = j.dump();
      if (binary_) {
        text.append((4 - text.size() % 4) % 4, ' ');
        const std::string rest(bytes.substr(bin_offset));
        const uint32_t chunk = static_cast<uint32_t>(text.size()), total = 20 + chunk + rest.size();
        prepared.assign("glTF", 4);
        for (uint32_t word : {2u, total, chunk, 0x4E4F534Au}) prepared.append(reinterpret_cast<const char*>(&word), 4);
        prepared += text + rest;
      } else {
        prepared = std::move(text);
      }
    }
  }
  Parsed parsed;
  if (prepared.empty() && early.valid()) {
    parsed = early.get();
  } else {
    if (early.valid()) early.wait();  // its result (or error) is for the file as it was: dropped
    parsed = parse(prepared.empty() ? bytes : std::string_view(prepared));
  }
  model_ = std::move(parsed.model);
  const bool ok = parsed.ok;
  const std::string& err = parsed.err;
  const std::string& warn = parsed.warn;
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
  // Images are decoded only for material channels, which report a missing
  // image file then (materials.cpp); tinygltf's warning is no concern of a
  // render without them. A missing buffer is an error.
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

void Loader::check_extensions() const {
  std::string unsupported;
  for (const std::string& ext : model_.extensionsRequired)
    if (!geometry_neutral(ext)) unsupported += (unsupported.empty() ? "" : ", ") + ext;
  if (!unsupported.empty()) fail("requires extensions rayfold does not support: " + unsupported);
}

bool Loader::uses_extension(const std::string& name) const {
  for (const std::string& e : model_.extensionsUsed)
    if (e == name) return true;
  return false;
}

}  // namespace rayfold::core::gltf
