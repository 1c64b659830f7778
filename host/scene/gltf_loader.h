// glTF 2.0 (.gltf and .glb) -> Scene. Keeps positions, indices and the node
// hierarchy's transforms; skips everything hit info does not need.
#pragma once

#include <cmath>
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
};

// Throws InputError naming the file and what is wrong (also for a scene or
// camera index the file does not have). Non-fatal oddities (points and
// lines skipped) are appended to warnings, one line per kind.
Scene load_gltf(const std::string& path, std::vector<std::string>* warnings = nullptr,
                const LoadOptions& options = {});

}  // namespace rayfold::core
