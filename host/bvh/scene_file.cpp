#include "bvh/scene_file.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <type_traits>

#include "util/checksum.h"
#include "util/errors.h"

namespace rayfold::core {
namespace {

constexpr size_t kHeader = 16 + 4 + 4 + 8;

// An alpha image the mask lookup can wrap in 32-bit ints (rf_alpha_wrap:
// a modulo by the size, twice the size for a mirror).
bool alpha_image_size_ok(uint32_t width, uint32_t height) {
  return width >= 1 && height >= 1 && width <= (1u << 30) && height <= (1u << 30);
}

uint32_t layout_signature() {
  return static_cast<uint32_t>(sizeof(rf_node)) | static_cast<uint32_t>(sizeof(rf_tri)) << 8 |
         static_cast<uint32_t>(sizeof(rf_wide_node)) << 16 | static_cast<uint32_t>(sizeof(rf_normal_xform)) << 24;
}

// Counts the bytes (out == nullptr), then writes them into a buffer of
// that size: one allocation for a scene of any size.
class Writer {
 public:
  explicit Writer(char* out = nullptr) : out_(out) {}
  template <class T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    append(&v, sizeof(T));
  }
  // Items without padding: device structs (their bytes documented in
  // kernels/rf_types.h), GLM vectors and matrices, integers.
  template <class T, class A>
  void put_all(const std::vector<T, A>& v) {
    put<uint64_t>(v.size());
    append(v.data(), v.size() * sizeof(T));
  }
  void put_string(const std::string& s) {
    put<uint64_t>(s.size());
    append(s.data(), s.size());
  }
  void put_spec(const CameraSpec& c) {
    put(c.eye);
    put(c.look_at);
    put(c.up);
    put(c.vfov_degrees);
    put<uint8_t>(c.orthographic);
    put(c.ymag);
  }
  size_t size() const { return size_; }

 private:
  void append(const void* p, size_t n) {
    if (out_ && n) std::memcpy(out_ + size_, p, n);
    size_ += n;
  }
  char* out_;
  size_t size_ = 0;
};

class Reader {
 public:
  Reader(const char* p, size_t n, const std::string& what) : p_(p), end_(p + n), what_(what) {}

  template <class T>
  T get() {
    T v;
    take(&v, sizeof(T));
    return v;
  }
  template <class T, class A = std::allocator<T>>
  std::vector<T, A> get_all() {
    const uint64_t n = get<uint64_t>();
    if (n > static_cast<uint64_t>(end_ - p_) / sizeof(T)) fail("a list runs past the end");
    std::vector<T, A> v(n);
    take(v.data(), n * sizeof(T));
    return v;
  }
  std::string get_string() {
    const uint64_t n = get<uint64_t>();
    if (n > static_cast<uint64_t>(end_ - p_)) fail("a name runs past the end");
    std::string s(p_, n);
    p_ += n;
    return s;
  }
  CameraSpec get_spec() {
    CameraSpec c;
    c.eye = get<glm::dvec3>();
    c.look_at = get<glm::dvec3>();
    c.up = get<glm::dvec3>();
    c.vfov_degrees = get<double>();
    c.orthographic = get<uint8_t>() != 0;
    c.ymag = get<double>();
    return c;
  }
  // A count of items of at least min_bytes each that the rest can hold.
  size_t count(size_t min_bytes) {
    const uint64_t n = get<uint64_t>();
    if (n > static_cast<uint64_t>(end_ - p_) / min_bytes) fail("a list runs past the end");
    return static_cast<size_t>(n);
  }
  bool done() const { return p_ == end_; }
  [[noreturn]] void fail(const std::string& why) const {
    throw InputError(what_, "is not a whole rayfold scene file: " + why);
  }

 private:
  void take(void* dst, size_t n) {
    if (n > static_cast<size_t>(end_ - p_)) fail("it ends early");
    if (n == 0) return;  // an empty list's data() may be null, which memcpy may not be given
    std::memcpy(dst, p_, n);
    p_ += n;
  }
  const char* p_;
  const char* end_;
  std::string what_;
};

}  // namespace

namespace {

void write_payload(Writer& w, const SceneFile& f, const std::string& rayfold_version) {
  w.put_string(rayfold_version);
  const Scene& s = f.scene;
  w.put<uint64_t>(s.meshes.size());
  for (const Mesh& m : s.meshes) {
    w.put_string(m.name);
    w.put_all(m.positions);
    w.put_all(m.indices);
    w.put_all(m.alpha);
  }
  w.put<uint64_t>(s.instances.size());
  for (const Instance& i : s.instances) {
    w.put(i.mesh);
    w.put(i.world_from_object);
    w.put_string(i.name);
    w.put(i.node);
  }
  w.put<uint8_t>(s.camera.has_value());
  if (s.camera) w.put_spec(*s.camera);
  w.put<uint64_t>(s.cameras.size());
  for (const Scene::FileCamera& c : s.cameras) {
    w.put_string(c.name);
    w.put(c.node);
    w.put<uint8_t>(c.perspective);
    w.put_spec(c.spec);
  }
  w.put<uint64_t>(s.scene_names.size());
  for (const std::string& n : s.scene_names) w.put_string(n);
  w.put(s.scene_index);
  w.put<uint64_t>(s.alpha_images.size());
  for (const AlphaImage& a : s.alpha_images) {
    w.put(a.width);
    w.put(a.height);
    w.put(a.wrap_s);
    w.put(a.wrap_t);
    w.put_all(a.alpha);
  }
  w.put_string(f.source);
  w.put<uint64_t>(f.warnings.size());
  for (const std::string& n : f.warnings) w.put_string(n);

  const SceneData& d = f.data;
  w.put_all(d.blas.nodes);
  w.put_all(d.blas.tris);
  w.put_all(d.blas.roots);
  w.put_all(d.blas.bounds);
  w.put_all(d.blas.tree_exponents);
  w.put_all(d.blas.traced_by);
  w.put_all(d.blas.instance_roots);
  w.put_all(d.blas.merged);
  w.put<uint64_t>(d.blas.unresolvable_triangles);
  w.put(d.blas.build_ms);
  w.put(d.blas.sah_cost);
  w.put(d.blas.max_depth);
  w.put_all(d.braid_offsets);
  w.put_all(d.braid_nodes);
  w.put_all(d.wide_nodes);
  w.put_all(d.braid_wide);
  w.put_all(d.tree_from_world);
  w.put_all(std::vector<uint8_t>(d.renderable.begin(), d.renderable.end()));
  w.put_all(d.normal_xforms);
  w.put(d.world_bounds);
  w.put(d.max_tree_scale);
  w.put<uint64_t>(d.hidden_instances);
  w.put_all(d.alpha.index);
  w.put_all(d.alpha.tris);
  w.put_all(d.alpha.images);
  w.put_all(d.alpha.texels);
}

}  // namespace

std::string scene_file_bytes(const SceneFile& f, const std::string& rayfold_version) {
  Writer count;
  write_payload(count, f, rayfold_version);
  const size_t length = count.size();
  std::string out(kHeader + length + 8, '\0');
  std::memcpy(out.data(), kSceneFileMagic, sizeof(kSceneFileMagic));
  const uint32_t format = kSceneFormat, layout = layout_signature();
  const uint64_t length64 = length;
  std::memcpy(out.data() + 16, &format, 4);
  std::memcpy(out.data() + 20, &layout, 4);
  std::memcpy(out.data() + 24, &length64, 8);
  Writer w(out.data() + kHeader);
  write_payload(w, f, rayfold_version);
  const uint64_t sum = fnv1a(out.data() + kHeader, length);
  std::memcpy(out.data() + kHeader + length, &sum, 8);
  return out;
}

namespace {

// The header checked (magic, format, device structs, length, checksum):
// the payload's bytes.
std::pair<const char*, uint64_t> check_header(const char* bytes, size_t size, const std::string& what) {
  Reader head(bytes, size, what);
  if (!is_scene_file(bytes, size)) head.fail("it does not start with \"rayfold-scene\"");
  if (size < kHeader + 8) head.fail("it ends early");
  uint32_t format, layout;
  uint64_t length;
  std::memcpy(&format, bytes + 16, 4);
  std::memcpy(&layout, bytes + 20, 4);
  std::memcpy(&length, bytes + 24, 8);
  if (format != kSceneFormat)
    throw InputError(what, "is a rayfold scene file of format " + std::to_string(format) + "; this rayfold reads " +
                               "format " + std::to_string(kSceneFormat) + ": save it again from the glTF file");
  if (layout != layout_signature())
    throw InputError(what, "is a rayfold scene file written with other device structs (another machine or "
                           "build): save it again here");
  if (length != size - kHeader - 8)
    head.fail("it holds " + std::to_string(size - kHeader - 8) + " payload bytes, its header says " +
              std::to_string(length));
  const char* payload = bytes + kHeader;
  uint64_t sum;
  std::memcpy(&sum, payload + length, 8);
  if (sum != fnv1a(payload, length)) head.fail("its checksum does not match (the file is damaged)");
  return {payload, length};
}

// The scene the trees were built from: meshes, instances, cameras, the
// alpha masks' images, the source's name and its warnings.
void read_scene(Reader& r, SceneFile& f) {
  Scene& s = f.scene;
  s.meshes.resize(r.count(3 * 8));
  for (Mesh& m : s.meshes) {
    m.name = r.get_string();
    m.positions = r.get_all<glm::vec3>();
    m.indices = r.get_all<uint32_t>();
    m.alpha = r.get_all<AlphaTriangle>();
    if (!m.alpha.empty() && m.alpha.size() != m.triangle_count())
      r.fail("a mesh's alpha masks do not match its triangles");
  }
  s.instances.resize(r.count(4 + 128 + 8 + 4));
  for (Instance& i : s.instances) {
    i.mesh = r.get<uint32_t>();
    i.world_from_object = r.get<Xform>();
    i.name = r.get_string();
    i.node = r.get<int>();
    if (i.mesh >= s.meshes.size()) r.fail("an instance names mesh " + std::to_string(i.mesh));
  }
  if (r.get<uint8_t>()) s.camera = r.get_spec();
  s.cameras.resize(r.count(8 + 4 + 1));
  for (Scene::FileCamera& c : s.cameras) {
    c.name = r.get_string();
    c.node = r.get<int>();
    c.perspective = r.get<uint8_t>() != 0;
    c.spec = r.get_spec();
  }
  s.scene_names.resize(r.count(8));
  for (std::string& n : s.scene_names) n = r.get_string();
  s.scene_index = r.get<int>();
  s.alpha_images.resize(r.count(4 + 4 + 4 + 4 + 8));
  for (AlphaImage& a : s.alpha_images) {
    a.width = r.get<uint32_t>();
    a.height = r.get<uint32_t>();
    a.wrap_s = r.get<int>();
    a.wrap_t = r.get<int>();
    a.alpha = r.get_all<uint8_t>();
    if (!alpha_image_size_ok(a.width, a.height)) r.fail("an alpha image is empty or wider or taller than 2^30");
    if (a.alpha.size() != uint64_t{a.width} * a.height) r.fail("an alpha image's texels do not match its size");
  }
  for (const Mesh& m : s.meshes)
    for (const AlphaTriangle& a : m.alpha)
      if (a.image >= 0 && static_cast<size_t>(a.image) >= s.alpha_images.size())
        r.fail("an alpha mask names an image the file does not hold");
  f.source = r.get_string();
  f.warnings.resize(r.count(8));
  for (std::string& n : f.warnings) n = r.get_string();
}

// The trees and the tables the kernels read.
void read_trees(Reader& r, SceneData& d) {
  d.blas.nodes = r.get_all<rf_node, PageAlignedAllocator<rf_node>>();
  d.blas.tris = r.get_all<rf_tri, PageAlignedAllocator<rf_tri>>();
  d.blas.roots = r.get_all<uint32_t>();
  d.blas.bounds = r.get_all<Aabb>();
  d.blas.tree_exponents = r.get_all<int>();
  d.blas.traced_by = r.get_all<uint32_t>();
  d.blas.instance_roots = r.get_all<uint32_t>();
  d.blas.merged = r.get_all<uint8_t>();
  d.blas.unresolvable_triangles = r.get<uint64_t>();
  d.blas.build_ms = r.get<double>();
  d.blas.sah_cost = r.get<double>();
  d.blas.max_depth = r.get<int>();
  d.braid_offsets = r.get_all<uint32_t>();
  d.braid_nodes = r.get_all<uint32_t>();
  d.wide_nodes = r.get_all<rf_wide_node, PageAlignedAllocator<rf_wide_node>>();
  d.braid_wide = r.get_all<uint32_t>();
  d.tree_from_world = r.get_all<Xform>();
  const std::vector<uint8_t> renderable = r.get_all<uint8_t>();
  d.renderable.assign(renderable.begin(), renderable.end());
  d.normal_xforms = r.get_all<rf_normal_xform>();
  d.world_bounds = r.get<Aabb>();
  d.max_tree_scale = r.get<int>();
  d.hidden_instances = r.get<uint64_t>();
  d.alpha.index = r.get_all<uint32_t>();
  d.alpha.tris = r.get_all<rf_alpha_tri>();
  d.alpha.images = r.get_all<rf_alpha_image>();
  d.alpha.texels = r.get_all<uint8_t>();
}

// The masks' tables: every index inside its array, every image's texels
// inside the texel array (the kernels read them unchecked).
void check_alpha_tables(const Reader& r, const SceneData& d) {
  const AlphaTables& a = d.alpha;
  // The writer gives a table of masks at least one image and one texel
  // (device buffers of one element or more).
  if (a.index.size() != (a.tris.empty() ? 0 : d.blas.tris.size()) || (a.tris.empty() && !a.images.empty()) ||
      (!a.tris.empty() && (a.images.empty() || a.texels.empty())))
    r.fail("its alpha tables do not match its trees");
  for (uint32_t k : a.index)
    if (k != RF_INVALID && k >= a.tris.size()) r.fail("an alpha table index lies outside its triangles");
  for (const rf_alpha_tri& t : a.tris)
    if (t.image != RF_INVALID && t.image >= a.images.size()) r.fail("an alpha triangle names an image past the last");
  for (const rf_alpha_image& i : a.images)
    if (!alpha_image_size_ok(i.width, i.height) ||
        uint64_t{i.offset} + uint64_t{i.width} * i.height > a.texels.size() || (i.wrap & 3u) > 2u ||
        (i.wrap >> 2 & 3u) > 2u || (i.wrap >> 4) != 0u)
      r.fail("an alpha image is empty, lies outside its texels or wraps by an unknown mode");
}

// The trees against the scene and themselves: per-instance and per-mesh
// lists of the scene's sizes, every index inside its array, no cycle, no
// tree deeper than the kernels' stack, every hit naming an instance.
void check_trees(const Reader& r, const Scene& s, const SceneData& d) {
  // The per-instance and per-mesh lists must agree with the scene (the
  // checksum vouches for the bytes, not for a writer's bugs).
  const size_t n = s.instances.size(), m = s.meshes.size();
  if (d.blas.roots.size() != m || d.blas.bounds.size() != m || d.blas.tree_exponents.size() != m ||
      d.tree_from_world.size() != n || d.renderable.size() != n || d.normal_xforms.size() != n ||
      d.blas.traced_by.size() != n || d.blas.instance_roots.size() != n || d.blas.merged.size() != n ||
      d.braid_offsets.size() != n + 1 || d.braid_wide.size() != d.braid_nodes.size() ||
      d.braid_offsets.back() != d.braid_nodes.size())
    r.fail("its trees do not match its meshes and instances");
  // Every index inside its array and every child after its parent: bytes
  // that passed the checksum still never send a traversal out of bounds or
  // round a cycle.
  const size_t nodes = d.blas.nodes.size(), tris = d.blas.tris.size(), wide = d.wide_nodes.size();
  // Each tree below a node a traversal starts from: indices inside their
  // arrays, no cycle, and no deeper than the kernels' stack. Heights are
  // kept per node, so shared subtrees are walked once.
  // Per node too, the largest rf_tri::inst below it: a hit's instance (the
  // traced instance's id plus it) must name an instance.
  std::vector<int> binary_height(nodes, -1), wide_height(wide, -1);  // -2: on the current path
  std::vector<uint32_t> binary_inst(nodes, 0), wide_inst(wide, 0);
  auto leaf_inst = [&](uint32_t first, uint32_t count) {
    uint32_t most = 0;
    for (uint32_t k = 0; k < count; ++k) most = std::max(most, d.blas.tris[first + k].inst);
    return most;
  };
  auto check = [&](uint32_t root, std::vector<int>& height, std::vector<uint32_t>& inst, auto&& children,
                   const char* what) {
    std::vector<std::pair<uint32_t, bool>> stack{{root, false}};
    while (!stack.empty()) {
      auto [i, expanded] = stack.back();
      stack.pop_back();
      if (expanded) {
        int h = 0;
        uint32_t most = 0;
        children(
            i,
            [&](uint32_t c) {
              h = std::max(h, height[c] + 1);
              most = std::max(most, inst[c]);
            },
            [&](uint32_t first, uint32_t count) { most = std::max(most, leaf_inst(first, count)); });
        if (h > RF_STACK_SIZE) r.fail(std::string(what) + " deeper than the traversal stack");
        height[i] = h;
        inst[i] = most;
        continue;
      }
      if (height[i] >= 0) continue;
      if (height[i] == -2) r.fail(std::string(what) + " with a cycle");
      height[i] = -2;
      stack.push_back({i, true});
      children(
          i,
          [&](uint32_t c) {
            if (height[c] == -2) r.fail(std::string(what) + " with a cycle");
            if (height[c] < 0) stack.push_back({c, false});
          },
          [](uint32_t, uint32_t) {});
    }
  };
  auto binary_children = [&](uint32_t i, auto&& visit, auto&& leaf) {
    const rf_node& node = d.blas.nodes[i];
    if (node.meta != 0) {
      if (size_t{node.first} + node.meta > tris) r.fail("a bottom-level leaf runs past the triangles");
      leaf(node.first, node.meta);
      return;
    }
    if (size_t{node.first} + 1 >= nodes) r.fail("a bottom-level node points outside the trees");
    visit(node.first);
    visit(node.first + 1);
  };
  auto wide_children = [&](uint32_t i, auto&& visit, auto&& leaf) {
    for (int k = 0; k < 4; ++k) {
      const uint32_t child = d.wide_nodes[i].child[k], count = d.wide_nodes[i].count[k];
      if (count == RF_INVALID) continue;
      if (count != 0 ? size_t{child} + count > tris : child >= wide) r.fail("a wide node points outside the trees");
      if (count == 0)
        visit(child);
      else
        leaf(child, count);
    }
  };
  auto check_tree = [&](uint32_t root) {
    check(root, binary_height, binary_inst, binary_children, "a bottom-level tree");
  };
  auto check_wide = [&](uint32_t root) { check(root, wide_height, wide_inst, wide_children, "a wide tree"); };
  for (uint32_t root : d.blas.roots) {
    if (root == RF_INVALID) continue;
    if (root >= nodes) r.fail("a mesh's root lies outside the trees");
    check_tree(root);
  }
  for (size_t i = 0; i < n; ++i) {
    const uint32_t root = d.blas.instance_roots[i];
    if (root != RF_INVALID && root >= nodes) r.fail("an instance's root lies outside the trees");
    if (root != RF_INVALID) {
      check_tree(root);
      // Ray queries trace the whole tree (FrameOptions::whole_trees), which
      // the cuts below need not cover.
      if (i + uint64_t{binary_inst[root]} >= n) r.fail("an instance's tree has triangles naming instances past the last");
    }
    if (d.blas.traced_by[i] >= n || d.blas.traced_by[d.blas.traced_by[i]] != d.blas.traced_by[i])
      r.fail("an instance is traced by one that is not traced by itself");
  }
  for (size_t i = 0; i < n; ++i) {
    if (d.braid_offsets[i] > d.braid_offsets[i + 1]) r.fail("the top-level items are out of order");
    for (size_t c = d.braid_offsets[i]; c < d.braid_offsets[i + 1]; ++c) {
      if (d.braid_nodes[c] >= nodes || (d.braid_wide[c] != RF_INVALID && d.braid_wide[c] >= wide))
        r.fail("a top-level item lies outside the trees");
      check_tree(d.braid_nodes[c]);
      uint64_t last = i + uint64_t{binary_inst[d.braid_nodes[c]]};
      if (d.braid_wide[c] != RF_INVALID) {
        check_wide(d.braid_wide[c]);
        last = std::max<uint64_t>(last, i + uint64_t{wide_inst[d.braid_wide[c]]});
      }
      if (last >= n) r.fail("a top-level item's triangles name instances past the last");
    }
  }
}

}  // namespace

SceneFile read_scene_file(const char* bytes, size_t size, const std::string& what, const std::string& rayfold_version) {
  const auto [payload, length] = check_header(bytes, size, what);
  Reader r(payload, length, what);
  const std::string version = r.get_string();
  if (version != rayfold_version)
    throw InputError(what, "was written by rayfold " + version + "; this is rayfold " + rayfold_version +
                               ", whose trees may differ: save it again from the glTF file");
  SceneFile f;
  read_scene(r, f);
  read_trees(r, f.data);
  if (!r.done()) r.fail("bytes follow the trees");
  check_alpha_tables(r, f.data);
  check_trees(r, f.scene, f.data);
  return f;
}

}  // namespace rayfold::core
