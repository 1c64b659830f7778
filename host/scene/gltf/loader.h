// The glTF loader's one class, whose stages live in the files beside it:
// document.cpp (the file and its checks), accessors.cpp (typed reads),
// pose.cpp (one pose of the whole scene), nodes.cpp (the hierarchy and
// instancing), meshes.cpp, attributes.cpp (what the channels read beside
// positions), materials.cpp, alpha_masks.cpp, cameras.cpp and animation.cpp
// (poses, morph targets, skins). host/scene/gltf_loader.h is the interface; this header
// is internal to the loader.
#pragma once

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <string_view>
#include <tuple>

#include <tiny_gltf.h>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>

#include "scene/gltf_decompress.h"
#include "util/errors.h"

#include "scene/gltf_loader.h"

namespace rayfold::core::gltf {

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
  Scene build(double time);

  void cache_meshes(bool on) { cache_meshes_ = on; }
  // The attributes build() keeps from now on (LoadOptions::attributes);
  // meshes converted before are converted again.
  void set_attributes(unsigned attributes) {
    if (attributes == options_.attributes) return;
    options_.attributes = attributes;
    converted_.clear();
  }
  unsigned attributes() const { return options_.attributes; }

  // The last keyframe time over the node animations; NaN without any.
  double animation_end() const;

  // Files whose tinygltf parse ran beside the checks' (read_model), in this
  // process: for the tests.
  static size_t side_by_side_reads() { return side_by_side_reads_; }

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
  // Each kind once over the file's life: a later pose or attribute read
  // (another time, materials decoded on first need) adds only kinds not
  // said before (not the same kind again with another node or count).
  void flush_warnings() {
    if (!warnings_) return;
    for (const Warning& w : pending_)
      if (said_.insert(w.kind).second)
        warnings_->push_back(path_ + ": " + w.first +
                             (w.more ? " (and " + std::to_string(w.more) + " more like it)" : std::string()));
  }

  // A file that is neither GLB nor JSON is some other format: say which, if
  // its extension tells, rather than report a JSON syntax error.
  void check_json_start(std::string_view bytes) const;

  // tinygltf reads a member of the wrong JSON type as absent: "primitives"
  // written as an object gives a mesh without triangles, silently. Every
  // member rayfold's reading depends on is checked against the glTF 2.0
  // schema's type, and a mismatch names its path.
  void check_schema_types(const nlohmann::json& j) const;

  // What tinygltf does not check: the GLB header's version and length, and
  // nodes that carry both a matrix and TRS (tinygltf silently drops the TRS).
  // Returns the parsed JSON (discarded when it does not parse) and, for a
  // GLB, sets *bin_offset to where the chunks after the JSON start.
  nlohmann::json check_raw(std::string_view bytes, size_t* bin_offset) const;

  void read_model();

  void check_extensions() const;

  std::vector<int> root_nodes();

  Xform local_transform(int ni);

  // T * R * S (glTF 2.0, 3.5.3); a missing part is the identity. A rotation
  // quaternion (x, y, z, w) that is not unit length is normalised, with a
  // warning.
  Xform trs(const double* t, const double* r, const double* s, const std::string& where);

  // EXT_mesh_gpu_instancing: the node's mesh drawn once per element of its
  // TRANSLATION, ROTATION and SCALE accessors, each transform applied before
  // the node's own. Empty when the node does not use it.
  std::vector<Xform> gpu_instances(int ni);

  // The node's name, or "node N" for an unnamed node (as the docs promise).
  std::string node_name(int ni) const;

  void add_camera(int ni, const Xform& world_from_node);

  // The camera the scene is rendered with: the one asked for, else the
  // file's first (as glTF viewers start with).
  void choose_camera();

  void add_instance(int ni, const Xform& world_from_node);

  // Morph targets at the default weights (glTF 2.0, 3.7.2.2): the node's,
  // else the mesh's, else 0; summed in double and rounded once. `attribute`:
  // the targets' POSITION (values: the positions) or NORMAL (the normals).
  void apply_morph_targets(int mi, size_t pi, const std::vector<double>& weights, const std::string& where,
                           std::vector<glm::vec3>& values, const char* attribute = "POSITION") const;

  // Every animation channel sampled at `time`, written over the node's TRS or
  // weights before the hierarchy is read (glTF 2.0, 3.11). Times outside a
  // sampler's keys hold its first or last value.
  void pose_at(double time);

  // Components per element of an accessor's type (VEC3: 3), for values read
  // whole; 0 refused.
  int components(int ai, const std::string& where) const;

  size_t weight_count(int ni) const;

  // One sampler's value at `time`: n components per key (3n for a cubic
  // spline: in-tangent, value, out-tangent).
  std::vector<double> sample(const tinygltf::AnimationSampler& s, int n, bool rotation, double time,
                             const std::string& where) const;

  // World transform of any node, whether or not the scene shows it (joints
  // may live outside the scene's hierarchy): its ancestors' transforms times
  // its own, memoised.
  Xform node_world(int ni);

  // A skin's joint matrices at the default pose: each joint's world
  // transform times its inverse bind matrix (identity when absent).
  std::vector<Xform> joint_matrices(int si);

  // Linear blend skinning (glTF 2.0, 3.7.3): each vertex moved by the
  // weighted sum of its joints' matrices, from every JOINTS_n / WEIGHTS_n
  // set; summed in double and rounded once. normals, when given, move by
  // the same weights of the joints' normal matrices (inverse transposes),
  // tangents' xyz by their linear parts; their length is the resolve's to
  // restore.
  void apply_skin(const tinygltf::Primitive& prim, const std::vector<Xform>& joints, const std::string& where,
                  std::vector<glm::vec3>& positions, std::vector<glm::vec3>* normals = nullptr,
                  std::vector<glm::vec4>* tangents = nullptr) const;

  // A primitive's NORMALs (attributes.cpp), morphed by its targets' NORMAL,
  // appended to out.normals for its vertex_count vertices (the caller skins
  // them with its positions); zeros and the missing bit for a primitive
  // without (scene/attributes.h).
  void read_normals(int mi, size_t pi, const std::string& where, size_t vertex_count,
                    const std::vector<double>& weights, MeshAttributes& out);
  // The primitive's other attributes options_.attributes asks for: texture
  // coordinates for its vertex_count vertices, its material for its
  // `triangles` new triangles; a primitive without texture coordinates gets
  // (0, 0) and the missing bit.
  void read_attributes(int mi, size_t pi, const std::string& where, size_t vertex_count, size_t triangles,
                       MeshAttributes& out);
  // A primitive's TANGENTs (VEC4: xyz and the bitangent's sign), xyz
  // morphed by its targets' TANGENT.
  std::vector<glm::vec4> read_tangents(int mi, size_t pi, const std::string& where, size_t vertex_count,
                                       const std::vector<double>& weights) const;
  // The primitive's tangents per corner of its triangles (from
  // triangle_first on) into mesh.attributes.tangents: `file_tangents` (per
  // vertex) when it has them, else MikkTSpace's (scene/tangents.h) from
  // the posed positions, the normals from normal_first on and the normal
  // texture's coordinate set (the missing bit where it has none).
  void add_corner_tangents(int mi, size_t pi, const std::string& where, Mesh& mesh, uint32_t base, size_t vertex_count,
                           size_t triangle_first, size_t normal_first, const std::vector<glm::vec4>& file_tangents);
  // The texture coordinate set a material's normalTexture reads (0 without one).
  int normal_texcoord_set(int material) const;
  // alpha_masks.cpp: a material's alpha mask, read on first use (its base
  // colour texture's alpha into alpha_images_); null for a material that is
  // not alphaMode MASK (BLEND: one warning, traced as opaque).
  struct AlphaMaterial {
    double cutoff = 0.5;
    double factor = 1.0;  // baseColorFactor's alpha
    TextureRef texture;   // its image an index into alpha_images_
  };
  const AlphaMaterial* mask_of(int material);
  // The primitive's triangles (from triangle_first on) appended to
  // mesh.alpha: their corners' texture coordinates and alpha under its
  // material's mask, or always kept.
  void add_alpha_masks(int mi, size_t pi, const std::string& where, Mesh& mesh, uint32_t base, size_t vertex_count,
                       size_t triangle_first);
  // COLOR_0 (VEC3 or VEC4 of FLOAT or normalized unsigned byte or short)
  // as linear RGBA.
  std::vector<glm::vec4> read_colors(int ai, const std::string& what) const;

  // materials.cpp: the materials and their decoded images, once
  // (materials_, images_), and the scene's labels, put into scene_ as
  // options_.attributes asks (kAttributeMaterialData, kAttributeLabel).
  void add_material_data();
  void read_materials();
  void read_every_material();  // read_materials' work, which may throw half-way
  // A textureInfo as a TextureRef, decoding its image (as sRGB or linear) on
  // first use; `where` names the material and texture for errors.
  TextureRef texture_ref(int index, int texcoord, const tinygltf::ExtensionMap& extensions, bool srgb,
                         const std::string& where);
  std::string image_name(int ii) const;
  // The image's encoded bytes: from its buffer view, its data: URI or its file.
  std::vector<uint8_t> image_bytes(int ii) const;
  // Per node, its label (LoadOptions::label_key) or its nearest labelled
  // ancestor's; "" for none.
  std::vector<std::string> node_labels() const;

  // Converts a glTF mesh (all its triangle primitives) into one Mesh; returns
  // its index in scene_.meshes, or -1 when it has no triangles.
  // This build's scene mesh. In an animated file a mesh without skin and
  // morph weights does not depend on the pose: it is converted once and
  // copied into later poses (GltfFile::scene_at per frame). Skinned meshes
  // follow their joints and weighted ones their (maybe animated) weights:
  // converted every time, so that no cache grows frame by frame.
  int mesh_for(int mi, const std::vector<double>& weights, int skin);

  int convert_mesh(int mi, const std::vector<double>& weights, int skin);

  static void append_triangles(int mode, std::vector<uint32_t>&& seq, uint32_t base, std::vector<uint32_t>& out,
                               size_t* dropped);

  bool uses_extension(const std::string& name) const;

  static size_t component_bytes(int type);

  // One component as glTF reads it (2.0, 3.11): FLOAT as stored, a
  // normalized integer mapped to [0, 1] or [-1, 1], any other integer as its
  // value.
  static double component(const unsigned char* p, int type, bool normalized);

  // `count` elements of `element_bytes` from view vi at `offset` with the
  // view's stride (or tightly packed): the bytes of element 0 and the
  // stride, after checking that the last element ends inside the view.
  const unsigned char* view_data(int vi, size_t offset, size_t count, size_t element_bytes, size_t align, bool is_index,
                                 const std::string& acc, size_t* stride) const;

  // An accessor's elements, `components` per element, as glTF reads them
  // (component()), with a sparse accessor's substitutions applied over its
  // base values (zeros without a buffer view).
  std::vector<double> read_elements(int ai, const std::string& what, int components, bool is_index) const;

  // A plain accessor's elements in place (neither sparse nor Draco-decoded,
  // of a known component type): element 0's bytes and the stride, checked
  // as read_elements checks them; nullptr for any other accessor, which
  // read_elements then reads (and reports). Positions and indices read
  // through it skip read_elements' doubles: fresh pages for 8 bytes a
  // component took half of loading the dragon.
  const unsigned char* plain_elements(int ai, const std::string& what, int components, bool is_index,
                                      size_t* stride) const;

  // Positions (and morph target displacements): VEC3 of FLOAT, or of
  // (normalized) integers as KHR_mesh_quantization allows.
  std::vector<glm::vec3> read_vec3(int ai, const std::string& what) const;
  // Texture coordinates: VEC2 of FLOAT or normalized unsigned byte or short
  // (glTF 2.0, 3.7.2.1), or another integer type with KHR_mesh_quantization.
  std::vector<glm::vec2> read_vec2(int ai, const std::string& what) const;

  void read_indices(int ai, const std::string& where, uint32_t vertex_count, std::vector<uint32_t>& out) const;

  struct Warning {
    std::string kind, first;
    size_t more;
  };
  std::string path_;
  std::vector<std::string>* warnings_;
  std::set<std::string> said_;  // the kinds flush_warnings has said
  LoadOptions options_;
  std::vector<Warning> pending_;
  bool binary_ = false;
  tinygltf::Model model_;
  static std::atomic<size_t> side_by_side_reads_;
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
  std::map<int, std::optional<AlphaMaterial>> alpha_materials_;  // mask_of's, by material
  std::vector<AlphaImage> alpha_images_;                         // the masks' images (Scene::alpha_images)
  std::map<std::tuple<int, int, int>, int> alpha_image_slot_;    // glTF image, wrapS, wrapT -> alpha_images_ index
  // The texture bits materials_ were read with (kAttributeMaterialData, kAttributeNormalTexture).
  unsigned materials_read_ = 0;
  std::vector<Material> materials_;
  std::vector<std::shared_ptr<const TextureImage>> images_;
  std::map<std::pair<int, bool>, int> image_slot_;  // (glTF image, sRGB) -> images_ index
  std::vector<Xform> world_;
  std::vector<char> world_known_;
};

}  // namespace rayfold::core::gltf
