// Materials, their textures and images (scene/materials.h), and the
// instances' labels from their nodes' extras: read only when a render's
// channels ask for them (kAttributeMaterialData, kAttributeLabel).
#include "scene/gltf/loader.h"
#include "scene/texture_image.h"

namespace rayfold::core::gltf {
namespace {

// A URI's %XX escapes decoded (glTF URIs are RFC 3986 references).
std::string percent_decoded(const std::string& uri) {
  std::string out;
  for (size_t i = 0; i < uri.size(); ++i) {
    if (uri[i] == '%' && i + 2 < uri.size() && std::isxdigit(static_cast<unsigned char>(uri[i + 1])) &&
        std::isxdigit(static_cast<unsigned char>(uri[i + 2]))) {
      out += static_cast<char>(std::stoi(uri.substr(i + 1, 2), nullptr, 16));
      i += 2;
    } else {
      out += uri[i];
    }
  }
  return out;
}

nlohmann::json to_json(const tinygltf::Value& v) {
  switch (v.Type()) {
    case tinygltf::BOOL_TYPE: return v.Get<bool>();
    case tinygltf::INT_TYPE: return v.Get<int>();
    case tinygltf::REAL_TYPE: return v.Get<double>();
    case tinygltf::STRING_TYPE: return v.Get<std::string>();
    case tinygltf::ARRAY_TYPE: {
      nlohmann::json a = nlohmann::json::array();
      for (size_t i = 0; i < v.ArrayLen(); ++i) a.push_back(to_json(v.Get(static_cast<int>(i))));
      return a;
    }
    case tinygltf::OBJECT_TYPE: {
      nlohmann::json o = nlohmann::json::object();
      for (const std::string& k : v.Keys()) o[k] = to_json(v.Get(k));
      return o;
    }
    default: return nullptr;
  }
}

bool valid_filter(int f, bool min) {
  return f == -1 || f == kNearest || f == kLinear ||
         (min && (f == kNearestMipmapNearest || f == kLinearMipmapNearest || f == kNearestMipmapLinear ||
                  f == kLinearMipmapLinear));
}
bool valid_wrap(int w) { return w == kClampToEdge || w == kMirroredRepeat || w == kRepeat; }

}  // namespace

std::string Loader::image_name(int ii) const {
  const std::string& name = model_.images[ii].name;
  return "image " + std::to_string(ii) + (name.empty() ? "" : " ('" + name + "')");
}

std::vector<uint8_t> Loader::image_bytes(int ii) const {
  const tinygltf::Image& im = model_.images[ii];
  const std::string name = image_name(ii);
  if (im.bufferView >= 0) {
    if (static_cast<size_t>(im.bufferView) >= model_.bufferViews.size())
      fail(name + " refers to buffer view " + std::to_string(im.bufferView) + ", which does not exist");
    size_t stride = 0;
    const size_t length = model_.bufferViews[im.bufferView].byteLength;
    const unsigned char* p = view_data(im.bufferView, 0, length, 1, 1, false, name, &stride);
    return std::vector<uint8_t>(p, p + length);
  }
  if (im.as_is) return im.image;  // a data: URI, kept encoded by the image callback (document.cpp)
  if (im.uri.empty()) fail(name + " has neither a buffer view nor a URI");
  const std::filesystem::path file = std::filesystem::path(path_).parent_path() / percent_decoded(im.uri);
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec))
    fail(name + ": file \"" + im.uri + "\" does not exist or is not a regular file (looked for " + file.string() + ")");
  std::ifstream in(file, std::ios::binary);
  std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in && !in.eof()) fail(name + ": reading " + file.string() + " failed: " + std::strerror(errno));
  return bytes;
}

TextureRef Loader::texture_ref(int index, int texcoord, const tinygltf::ExtensionMap& extensions, bool srgb,
                               const std::string& where) {
  TextureRef ref;
  if (index < 0) return ref;
  if (static_cast<size_t>(index) >= model_.textures.size())
    fail(where + " refers to texture " + std::to_string(index) + ", which does not exist");
  const tinygltf::Texture& t = model_.textures[index];
  const std::string tex = "texture " + std::to_string(index);
  if (t.source < 0) {
    std::string by;
    for (const auto& e : t.extensions) by += (by.empty() ? "" : ", ") + e.first;
    fail(where + ": " + tex + " has no PNG or JPEG source" +
         (by.empty() ? "" : " (its image is given only by " + by + ", which rayfold does not decode)"));
  }
  if (static_cast<size_t>(t.source) >= model_.images.size())
    fail(where + ": " + tex + " refers to image " + std::to_string(t.source) + ", which does not exist");
  if (t.sampler >= 0) {
    if (static_cast<size_t>(t.sampler) >= model_.samplers.size())
      fail(where + ": " + tex + " refers to sampler " + std::to_string(t.sampler) + ", which does not exist");
    const tinygltf::Sampler& s = model_.samplers[t.sampler];
    const std::string sampler = "sampler " + std::to_string(t.sampler);
    if (!valid_filter(s.magFilter, false)) fail(sampler + " has magFilter " + std::to_string(s.magFilter));
    if (!valid_filter(s.minFilter, true)) fail(sampler + " has minFilter " + std::to_string(s.minFilter));
    if (!valid_wrap(s.wrapS)) fail(sampler + " has wrapS " + std::to_string(s.wrapS));
    if (!valid_wrap(s.wrapT)) fail(sampler + " has wrapT " + std::to_string(s.wrapT));
    if (s.magFilter != -1) ref.sampler.mag = s.magFilter;
    if (s.minFilter != -1) ref.sampler.min = s.minFilter;
    ref.sampler.wrap_s = s.wrapS;
    ref.sampler.wrap_t = s.wrapT;
  }
  ref.texcoord = texcoord;
  const auto transform = extensions.find("KHR_texture_transform");
  if (transform != extensions.end()) {
    const nlohmann::json x = to_json(transform->second);
    auto pair = [&](const char* key, double fallback) {
      glm::dvec2 v(fallback);
      if (!x.contains(key)) return v;
      const nlohmann::json& a = x[key];
      if (!a.is_array() || a.size() != 2 || !a[0].is_number() || !a[1].is_number())
        fail(where + ": KHR_texture_transform's " + key + " must be two numbers");
      return glm::dvec2(a[0].get<double>(), a[1].get<double>());
    };
    const glm::dvec2 offset = pair("offset", 0.0), scale = pair("scale", 1.0);
    double rotation = 0.0;
    if (x.contains("rotation")) {
      if (!x["rotation"].is_number()) fail(where + ": KHR_texture_transform's rotation must be a number");
      rotation = x["rotation"].get<double>();
    }
    if (x.contains("texCoord")) {
      if (!x["texCoord"].is_number_integer()) fail(where + ": KHR_texture_transform's texCoord must be an integer");
      ref.texcoord = x["texCoord"].get<int>();
    }
    // Column-major: translation * rotation * scale as the extension writes them.
    const double c = std::cos(rotation), s = std::sin(rotation);
    ref.uv_transform = glm::dmat3(glm::dvec3(c * scale.x, -s * scale.x, 0.0), glm::dvec3(s * scale.y, c * scale.y, 0.0),
                                  glm::dvec3(offset.x, offset.y, 1.0));
  }
  if (ref.texcoord < 0 || ref.texcoord > 1)
    fail(where + " reads TEXCOORD_" + std::to_string(ref.texcoord) + "; rayfold reads TEXCOORD_0 and TEXCOORD_1");
  const std::pair<int, bool> key(t.source, srgb);
  auto found = image_slot_.find(key);
  if (found == image_slot_.end()) {
    const std::vector<uint8_t> bytes = image_bytes(t.source);
    images_.push_back(std::make_shared<const TextureImage>(
        decode_texture_image(bytes.data(), bytes.size(), srgb, path_, image_name(t.source))));
    if (images_.back()->reduced_from_16_bits)
      warn(image_name(t.source) + " is a 16-bit PNG: decoded at 8 bits a channel (rayfold keeps 8-bit texels)");
    found = image_slot_.emplace(key, static_cast<int>(images_.size() - 1)).first;
  }
  ref.image = found->second;
  return ref;
}

void Loader::read_materials() {
  // Read again when more of their textures are asked for; decoded images are kept.
  const unsigned asked = options_.attributes & (kAttributeMaterialData | kAttributeNormalTexture);
  if ((materials_read_ & asked) == asked) return;
  materials_.clear();
  try {
    read_every_material();
  } catch (...) {
    // Nothing half-read is kept: the next build reads them again.
    materials_.clear();
    images_.clear();
    image_slot_.clear();
    materials_read_ = 0;
    throw;
  }
  materials_read_ = asked;
}

void Loader::read_every_material() {
  for (size_t mi = 0; mi < model_.materials.size(); ++mi) {
    const tinygltf::Material& m = model_.materials[mi];
    const std::string where = "material " + std::to_string(mi) + (m.name.empty() ? "" : " ('" + m.name + "')");
    Material out;
    out.name = m.name;
    const tinygltf::PbrMetallicRoughness& pbr = m.pbrMetallicRoughness;
    if (pbr.baseColorFactor.size() != 4) fail(where + ": baseColorFactor must have 4 numbers");
    if (m.emissiveFactor.size() != 3) fail(where + ": emissiveFactor must have 3 numbers");
    for (int c = 0; c < 4; ++c) out.base_color_factor[c] = pbr.baseColorFactor[c];
    for (int c = 0; c < 3; ++c) out.emissive_factor[c] = m.emissiveFactor[c];
    out.metallic_factor = pbr.metallicFactor;
    out.roughness_factor = pbr.roughnessFactor;
    // Each texture decoded only for the channels that read it.
    if (options_.attributes & kAttributeMaterialData) {
      out.base_color = texture_ref(pbr.baseColorTexture.index, pbr.baseColorTexture.texCoord,
                                   pbr.baseColorTexture.extensions, true, where + "'s baseColorTexture");
      out.metallic_roughness =
          texture_ref(pbr.metallicRoughnessTexture.index, pbr.metallicRoughnessTexture.texCoord,
                      pbr.metallicRoughnessTexture.extensions, false, where + "'s metallicRoughnessTexture");
      out.emissive = texture_ref(m.emissiveTexture.index, m.emissiveTexture.texCoord, m.emissiveTexture.extensions,
                                 true, where + "'s emissiveTexture");
    }
    if (options_.attributes & kAttributeNormalTexture) {
      out.normal = texture_ref(m.normalTexture.index, m.normalTexture.texCoord, m.normalTexture.extensions, false,
                               where + "'s normalTexture");
      out.normal_scale = m.normalTexture.scale;
      if (!std::isfinite(out.normal_scale)) fail(where + ": normalTexture's scale must be a finite number");
    }
    const auto strength = m.extensions.find("KHR_materials_emissive_strength");
    if (strength != m.extensions.end()) {
      const nlohmann::json x = to_json(strength->second);
      if (x.contains("emissiveStrength")) {
        if (!x["emissiveStrength"].is_number() || !(x["emissiveStrength"].get<double>() >= 0.0))
          fail(where + ": KHR_materials_emissive_strength's emissiveStrength must be a number >= 0");
        out.emissive_strength = x["emissiveStrength"].get<double>();
      }
    }
    double factors[9] = {out.metallic_factor, out.roughness_factor};
    for (int c = 0; c < 4; ++c) factors[2 + c] = out.base_color_factor[c];
    for (int c = 0; c < 3; ++c) factors[6 + c] = out.emissive_factor[c];
    for (double v : factors)
      if (!std::isfinite(v)) fail(where + " has a factor that is not finite");
    materials_.push_back(std::move(out));
  }
}

std::vector<std::string> Loader::node_labels() const {
  const size_t n = model_.nodes.size();
  std::vector<int> parent(n, -1);
  for (size_t i = 0; i < n; ++i)
    for (int c : model_.nodes[i].children)
      if (c >= 0 && static_cast<size_t>(c) < n) parent[c] = static_cast<int>(i);
  std::vector<std::string> own(n);
  std::vector<char> has(n, 0);
  for (size_t i = 0; i < n; ++i) {
    const tinygltf::Value& extras = model_.nodes[i].extras;
    if (options_.label_key.empty()) {
      if (extras.Type() == tinygltf::NULL_TYPE) continue;
      own[i] = to_json(extras).dump();
    } else {
      if (!extras.IsObject() || !extras.Has(options_.label_key)) continue;
      const nlohmann::json v = to_json(extras.Get(options_.label_key));
      own[i] = v.is_string() ? v.get<std::string>() : v.dump();
    }
    has[i] = 1;
  }
  // The nearest labelled ancestor's (the hierarchy was checked acyclic by build()).
  std::vector<std::string> out(n);
  for (size_t i = 0; i < n; ++i) {
    int a = static_cast<int>(i);
    for (size_t steps = 0; a >= 0 && !has[a] && steps <= n; ++steps) a = parent[a];
    if (a >= 0 && has[a]) out[i] = own[a];
  }
  return out;
}

void Loader::add_material_data() {
  if (options_.attributes & (kAttributeMaterialData | kAttributeNormalTexture)) {
    read_materials();
    scene_.materials = materials_;
    scene_.images = images_;
  }
  if (options_.attributes & kAttributeLabel) {
    const std::vector<std::string> labels = node_labels();
    // A key no node has labels every instance '': most likely a misspelling.
    if (!options_.label_key.empty() &&
        std::all_of(labels.begin(), labels.end(), [](const std::string& l) { return l.empty(); }))
      warn("no node's extras has the label key '" + options_.label_key + "': every instance's label is '' (0)");
    std::map<std::string, uint32_t> index{{"", 0}};
    scene_.labels = {""};
    for (Instance& inst : scene_.instances) {
      if (inst.node < 0) continue;
      const std::string& text = labels[inst.node];
      auto found = index.find(text);
      if (found == index.end()) {
        found = index.emplace(text, static_cast<uint32_t>(scene_.labels.size())).first;
        scene_.labels.push_back(text);
      }
      inst.label = found->second;
    }
  }
}

}  // namespace rayfold::core::gltf
