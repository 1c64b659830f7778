// A scene: meshes (positions and triangles) and instances placing them in
// the world. From a glTF 2.0 file or built in memory; instances can move
// between renders.
#pragma once

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rayfold/camera.h"
#include "rayfold/types.h"

namespace rayfold {
namespace detail {
struct SceneState;
}

struct LoadOptions {
  int scene = -1;     // the file's scene to show; -1: its default scene, else scene 0
  int camera = -1;    // the file's camera to use (index into camera_names()); -1: the first perspective one
  double time = NAN;  // seconds: every node animation posed at this time; NaN: the rest pose
  unsigned threads = 0;  // threads decoding the file's buffers; 0: all cores
  // The channels (Channels) renders will ask for: the attributes they read
  // (normals, texture coordinates, materials) are read now rather than on
  // the first render that asks for them. 0: none yet.
  unsigned channels = 0;
  // The member of a node's `extras` whose value labels it for the label
  // channel (kLabel), e.g. "category" for {"category": "chair"}; empty: the
  // whole extras value. A node without one takes its nearest labelled
  // ancestor's.
  std::string label_key;
};

// Where Scene::default_view's view comes from.
enum class ViewSource {
  file_camera,  // the file's camera (LoadOptions::camera)
  object,       // chosen: the whole scene from outside
  interior,     // chosen: an interior, from inside, looking along it
};

// A handle: copies share one scene, and a Renderer keeps it alive. Not safe
// to change while a render of it runs.
class Scene {
 public:
  Scene();  // empty, to be filled with add_mesh and add_instance

  // Loads a .gltf or .glb file, or a scene file save() wrote (told apart by
  // its first bytes; options then must be the defaults). Throws InputError
  // naming the file and what is wrong; non-fatal oddities (points and lines
  // skipped) go to warnings().
  static Scene load(const std::string& path, const LoadOptions& options = {});

  // The scene and its bottom-level trees as bytes, in a versioned,
  // checksummed format (host/bvh/scene_file.h); the trees are built now if
  // no earlier call built them, and kept. from_bytes reads such bytes back,
  // trees and all, so a Renderer of it builds none (and renders the bits of
  // the original); InputError, naming `what`, for bytes cut short, damaged,
  // or written by another rayfold version or machine. save writes the
  // bytes to a file (whole or not at all; RuntimeFailure naming it).
  // A scene from a file keeps path() and warnings(), but not its
  // animations (set_time).
  std::string to_bytes() const;
  static Scene from_bytes(const std::string& bytes, const std::string& what = "scene bytes");
  static Scene from_bytes(const char* bytes, size_t size, const std::string& what = "scene bytes");
  void save(const std::string& path) const;

  // Adds a mesh: positions x, y, z per vertex (object space), three vertex
  // indices per triangle; returns its index. Throws InputError for indices
  // out of range, a count not a multiple of 3, or positions not finite.
  uint32_t add_mesh(const float* positions, size_t vertex_count, const uint32_t* indices, size_t index_count,
                    const std::string& name = "");
  uint32_t add_mesh(const std::vector<float>& positions, const std::vector<uint32_t>& indices,
                    const std::string& name = "");
  // Places a mesh in the world; returns the instance's index, the
  // instance_id of its pixels. Throws InputError for a bad mesh index or a
  // matrix that is not finite and affine.
  uint32_t add_instance(uint32_t mesh, const Matrix4& world_from_object, const std::string& name = "");
  // Moves an instance: the next render shows it there, without rebuilding
  // its mesh's tree. Throws InputError as add_instance does, and for world
  // coordinates beyond 2^126.
  void set_transform(uint32_t instance, const Matrix4& world_from_object);
  Matrix4 transform(uint32_t instance) const;
  // Poses a loaded file's animations at `seconds` (NaN: the rest pose), as
  // LoadOptions::time does at load: moved nodes move their instances (as
  // set_transform does); animated morph weights or skins replace the meshes,
  // and the next render rebuilds the trees. Throws InputError for a scene not
  // loaded from a file, or animation data that is broken.
  void set_time(double seconds);
  double time() const;           // the pose's time (set_time, LoadOptions::time); NaN: the rest pose
  bool animated() const;         // the file animates nodes
  double animation_end() const;  // its last keyframe, seconds; 0 when not animated

  size_t mesh_count() const;
  size_t instance_count() const;
  size_t triangle_count() const;  // over instances, as rendered
  size_t stored_triangle_count() const;  // over meshes, as stored (a mesh many instances show counts once)
  uint32_t instance_mesh(uint32_t instance) const;
  // A mesh's object-space positions (x, y, z per vertex) and triangles (three
  // indices each, primitive_id indexing triangles), as stored: to look a hit
  // up. Throws InputError for a bad index.
  std::vector<float> mesh_positions(uint32_t mesh) const;
  std::vector<uint32_t> mesh_indices(uint32_t mesh) const;
  // The node name of each instance (glTF: the node's name, "node N" when
  // unnamed, "<node>[i]" for GPU instances), indexed by instance_id.
  std::vector<std::string> instance_names() const;
  // The glTF node of each instance (many files repeat node names), -1 for
  // one added in memory; the name of each mesh (the glTF mesh's, "mesh N"
  // when unnamed, as add_mesh was given it otherwise).
  std::vector<int> instance_nodes() const;
  std::vector<std::string> mesh_names() const;
  // The label channel's table (kLabel): label i's text, a string value as
  // is, any other as JSON; label 0 is "", no label. Read from the file on
  // the first call or render that asks.
  std::vector<std::string> labels() const;
  const std::string& path() const;  // the file loaded; empty for a scene built in memory
  const std::vector<std::string>& warnings() const;

  // The file's cameras by node name, in node order (LoadOptions::camera
  // indexes them; perspective and orthographic alike).
  std::vector<std::string> camera_names() const;
  // The file's cameras as views, in camera_names()'s order, with the glTF
  // node each hangs from; the file's scenes (names, "" when unnamed) and
  // the one shown (LoadOptions::scene; -1 when the file has none).
  struct FileCamera {
    std::string name;
    int node = -1;
    View view;
  };
  std::vector<FileCamera> file_cameras() const;
  std::vector<std::string> scene_names() const;
  int scene_index() const;
  // The chosen file camera (LoadOptions::camera) at this image size, or, for a
  // file without one and a scene built in memory, a view chosen from the
  // scene: an object whole from outside, an interior from inside, looking
  // along it (as `rayfold render` frames it). Choosing traces small probe
  // images on the CPU over the scene's trees, built here if no renderer has
  // built them yet (renderers then share them): Sponza about 40 ms.
  Camera default_camera(int width, int height) const;
  // The view default_camera makes its camera of (Camera::from_view), and
  // where it comes from: to change one of its values (the CLI's --up alone
  // turns the file's camera) and keep the rest.
  View default_view(ViewSource* source = nullptr) const;
  bool has_camera() const;  // the file gave a camera (LoadOptions::camera): default_view is then its view
  // World-space bounds of the instances at rest: min x, y, z and max x, y, z
  // (all 0 for a scene of no triangles).
  std::array<double, 6> bounds() const;

  const std::shared_ptr<detail::SceneState>& state() const { return state_; }

 private:
  std::shared_ptr<detail::SceneState> state_;
};

}  // namespace rayfold
