// Typed reads of accessors and buffer views: components, normalisation,
// strides, sparse values, indices.
#include "scene/gltf/loader.h"

namespace rayfold::core::gltf {

int Loader::components(int ai, const std::string& where) const {
  if (ai < 0 || static_cast<size_t>(ai) >= model_.accessors.size())
    fail(where + ": accessor " + std::to_string(ai) + " does not exist");
  const int n = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(model_.accessors[ai].type));
  if (n <= 0) fail(where + ": accessor " + std::to_string(ai) + " has an unknown type");
  return n;
}

size_t Loader::component_bytes(int type) {
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

double Loader::component(const unsigned char* p, int type, bool normalized) {
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

const unsigned char* Loader::view_data(int vi, size_t offset, size_t count, size_t element_bytes, size_t align,
                                       bool is_index, const std::string& acc, size_t* stride) const {
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

const unsigned char* Loader::plain_elements(int ai, const std::string& what, int components, bool is_index,
                                            size_t* stride) const {
  if (ai < 0 || static_cast<size_t>(ai) >= model_.accessors.size() || decoded_.count(ai) != 0) return nullptr;
  const tinygltf::Accessor& a = model_.accessors[ai];
  const size_t cb = component_bytes(a.componentType);
  if (cb == 0 || a.sparse.isSparse || a.bufferView < 0 || a.count == 0) return nullptr;
  const std::string acc = what + " accessor " + std::to_string(ai);
  if (a.count > (size_t(1) << 31)) fail(acc + " has " + std::to_string(a.count) + " elements, too many");
  return view_data(a.bufferView, a.byteOffset, a.count, cb * static_cast<size_t>(components), cb, is_index, acc,
                   stride);
}

std::vector<double> Loader::read_elements(int ai, const std::string& what, int components, bool is_index) const {
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
      fail(acc + " is sparse with " + std::to_string(a.sparse.count) + " substitutions for " + std::to_string(a.count) +
           " elements");
    const int it = a.sparse.indices.componentType;
    if (it != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE && it != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
        it != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
      fail(acc + ": sparse indices must be unsigned byte, short or int");
    size_t istride = 0, vstride = 0;
    const unsigned char* ip =
        view_data(a.sparse.indices.bufferView, a.sparse.indices.byteOffset, n, component_bytes(it), component_bytes(it),
                  true, acc + " (sparse indices)", &istride);
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

std::vector<glm::vec3> Loader::read_vec3(int ai, const std::string& what) const {
  if (ai >= 0 && static_cast<size_t>(ai) < model_.accessors.size()) {
    const tinygltf::Accessor& a = model_.accessors[ai];
    if (a.type != TINYGLTF_TYPE_VEC3) fail(what + " accessor " + std::to_string(ai) + " must be VEC3");
    if (a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
      fail(what + " accessor " + std::to_string(ai) + " must be FLOAT or (normalized) byte or short");
    if (a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT && !uses_extension("KHR_mesh_quantization"))
      fail(what + " accessor " + std::to_string(ai) +
           " holds integers, which glTF 2.0 allows only with KHR_mesh_quantization in extensionsUsed");
  }
  std::vector<glm::vec3> out;
  size_t stride = 0;
  const unsigned char* p = plain_elements(ai, what, 3, false, &stride);
  if (p != nullptr && model_.accessors[ai].componentType == TINYGLTF_COMPONENT_TYPE_FLOAT) {
    // FLOAT as stored, which is what component() gives through a double.
    out.resize(model_.accessors[ai].count);
    for (size_t i = 0; i < out.size(); ++i) std::memcpy(&out[i], p + i * stride, sizeof(glm::vec3));
  } else {
    const std::vector<double> e = read_elements(ai, what, 3, false);
    out.resize(e.size() / 3);
    for (size_t i = 0; i < out.size(); ++i)
      out[i] =
          glm::vec3(static_cast<float>(e[3 * i]), static_cast<float>(e[3 * i + 1]), static_cast<float>(e[3 * i + 2]));
  }
  for (size_t i = 0; i < out.size(); ++i)
    if (!std::isfinite(out[i].x) || !std::isfinite(out[i].y) || !std::isfinite(out[i].z))
      fail(what + " " + std::to_string(i) + " is not finite");
  return out;
}

void Loader::read_indices(int ai, const std::string& where, uint32_t vertex_count, std::vector<uint32_t>& out) const {
  if (ai < 0 || static_cast<size_t>(ai) >= model_.accessors.size())
    fail(where + ": index accessor " + std::to_string(ai) + " does not exist");
  const tinygltf::Accessor& a = model_.accessors[ai];
  if (a.type != TINYGLTF_TYPE_SCALAR) fail(where + ": indices must be SCALAR");
  if (a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
      a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
      a.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
    fail(where + ": indices must be unsigned byte, short or int");
  auto check = [&](size_t i, uint64_t v) {
    if (v >= vertex_count)
      fail(where + ": index " + std::to_string(i) + " is " + std::to_string(v) + ", past the " +
           std::to_string(vertex_count) + " vertices");
    out[i] = static_cast<uint32_t>(v);
  };
  size_t stride = 0;
  const unsigned char* p = plain_elements(ai, where + ": index", 1, true, &stride);
  if (p != nullptr) {
    out.resize(a.count);
    auto read = [&](auto type) {
      // Read, then checked by their largest: a check per index kept the
      // loop from vectorising. The first index past the vertices is then
      // found for the message.
      uint32_t largest = 0;
      for (size_t i = 0; i < out.size(); ++i) {
        decltype(type) v;
        std::memcpy(&v, p + i * stride, sizeof v);
        out[i] = v;
        largest = std::max<uint32_t>(largest, v);
      }
      if (largest >= vertex_count)
        for (size_t i = 0; i < out.size(); ++i) check(i, out[i]);
    };
    if (a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT)
      read(uint32_t{});
    else if (a.componentType == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT)
      read(uint16_t{});
    else
      read(uint8_t{});
    return;
  }
  const std::vector<double> e = read_elements(ai, where + ": index", 1, true);
  out.resize(e.size());
  for (size_t i = 0; i < e.size(); ++i) check(i, static_cast<uint64_t>(e[i]));
}

}  // namespace rayfold::core::gltf
