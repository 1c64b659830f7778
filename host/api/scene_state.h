// What a public Scene handle shares: the core scene and what tells a
// Renderer that it changed.
#pragma once

#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "bvh/scene_data.h"
#include "scene/camera.h"
#include "scene/gltf_loader.h"
#include "scene/scene.h"

namespace rayfold::detail {

struct SceneState {
  core::Scene scene;
  std::string path;
  std::shared_ptr<core::GltfFile> file;  // the file read once, for set_time
  std::vector<std::string> warnings;
  double time = NAN;  // the pose the file's scene is in (LoadOptions::time, set_time)
  // The attributes (core::Attribute bits) whose absence from some mesh the
  // warnings have named already (resolve_gbuffer.h, load_attributes).
  unsigned attributes_named = 0;
  // Bumped when meshes or instances are added: a renderer rebuilds its trees.
  uint64_t structure_version = 0;
  // Per instance, the clock value of its last set_transform (0: as added).
  std::vector<uint64_t> moved_at;
  uint64_t clock = 0;
  // The trees, for the structure_version and clock they were built at (by
  // the first renderer, Scene::to_bytes or read by Scene::from_bytes): every
  // renderer shares them instead of building, moving instances set_transform
  // moved since.
  std::shared_ptr<const core::SceneData> trees;
  uint64_t trees_version = 0, trees_clock = 0;
  // The view Scene::default_camera chose over those trees (a file without a
  // camera), for the trees it was chosen on.
  std::shared_ptr<const core::SceneData> framed_on;
  core::CameraSpec framed;
  bool framed_interior = false;  // framed from inside (core::ViewKind::interior)

  // Which instances trees built now keep apart (bvh/blas.h): those
  // set_transform or set_time has moved; the others may share a tree.
  core::MergeOptions merge() const {
    core::MergeOptions m;
    m.dynamic.resize(moved_at.size());
    for (size_t i = 0; i < moved_at.size(); ++i) m.dynamic[i] = moved_at[i] != 0;
    return m;
  }
};

// The file posed again (scene_at) with what that reading said that the
// file had not said before (GltfFile::warnings' new lines).
std::pair<core::Scene, std::vector<std::string>> pose_file(core::GltfFile& file, double time);

// The trees for the scene as it is now (every instance where set_transform
// and set_time put it): s.trees, built first if the scene changed since.
std::shared_ptr<const core::SceneData> current_trees(SceneState& s);

// Poses the file's scene at `seconds` (Scene::set_time); InputError naming
// `caller` for a scene without a file.
void pose_at(SceneState& s, double seconds, const char* caller);

// Runs body with the scene posed at `seconds`, then puts the scene back as it
// was however body ends: its instances and transforms (set_transform's moves,
// instances added), meshes and time. Renderers see the moves as moves, or
// rebuild where the meshes changed.
void at_pose(SceneState& s, double seconds, const char* caller, const std::function<void()>& body);

}  // namespace rayfold::detail
