// glTF 2.0 (.gltf and .glb) -> Scene. Keeps positions, indices and the node
// hierarchy's transforms, and the vertex attributes and materials asked for
// (LoadOptions::attributes); skips everything else.
#pragma once

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "scene/scene.h"

namespace rayfold::core {

struct LoadOptions {
  int scene = -1;   // the file's scene to show; -1: its `scene`, else scene 0
  int camera = -1;  // index into Scene::cameras of the camera to use; -1: the first perspective one
  // Seconds: the pose of every node animation of the file at this time (its
  // translation, rotation, scale and morph weights channels; step, linear
  // with slerp for rotations, and cubic spline). NaN: the file's rest pose.
  double time = NAN;
  // Threads the reading may use (0: every core): with two or more,
  // tinygltf parses the file while rayfold's own checks parse its JSON.
  unsigned threads = 0;
  // The attributes to keep (scene/attributes.h, Attribute bits): none by
  // default, what hit info alone needs.
  unsigned attributes = 0;
  // The member of a node's `extras` whose value is its label
  // (kAttributeLabel), e.g. "category"; empty: the whole extras value. A
  // node without one takes its nearest labelled ancestor's.
  std::string label_key;
};

// A glTF file read once and posed at any time: each frame of its
// animations without reading the file again.
class GltfFile {
 public:
  // Reads and checks the file; throws InputError as load_gltf does.
  GltfFile(const std::string& path, const LoadOptions& options = {});
  ~GltfFile();
  // The scene posed at `time` seconds (NaN: the rest pose; options.time is
  // not used here). Throws InputError for animation data that is broken.
  Scene scene_at(double time);
  // From now on scene_at keeps these attributes (Attribute bits) too: the
  // positions, indices and transforms it gives are those it gave before.
  void set_attributes(unsigned attributes);
  unsigned attributes() const;
  bool animated() const;         // the file animates nodes (transforms or morph weights)
  double animation_end() const;  // the last keyframe, seconds; 0 when not animated
  // Non-fatal oddities, one line per kind, each once: the first scene_at's,
  // then what later ones found new (a pose, an image decoded on first need)
  // appended.
  const std::vector<std::string>& warnings() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string path_;
};

// Whether two poses of one file share their meshes (only instance transforms
// differ): then a renderer moves instances instead of rebuilding trees.
bool same_geometry(const Scene& a, const Scene& b);

// Puts a new pose of the same file (GltfFile::scene_at) into `scene`. With
// the same meshes only instance transforms change: the instances whose
// transform changed are appended to `moved`, and the result is false. With
// other meshes (animated morph weights or skins) the scene is replaced and
// the result is true: a renderer's trees must be built again.
bool apply_pose(Scene& scene, Scene&& posed, std::vector<uint32_t>* moved);

// Throws InputError naming the file and what is wrong (also for a scene or
// camera index the file does not have). Non-fatal oddities (points and
// lines skipped) are appended to warnings, one line per kind.
Scene load_gltf(const std::string& path, std::vector<std::string>* warnings = nullptr,
                const LoadOptions& options = {});

}  // namespace rayfold::core
