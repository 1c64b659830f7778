// glTF 2.0 (.gltf and .glb) -> Scene. Keeps positions, indices and the node
// hierarchy's transforms; skips everything hit info does not need.
#pragma once

#include <string>
#include <vector>

#include "scene/scene.h"

namespace rayfold {

// Throws InputError naming the file and what is wrong. Non-fatal oddities
// (points and lines skipped, images not found) are appended to warnings.
Scene load_gltf(const std::string& path, std::vector<std::string>* warnings = nullptr);

}  // namespace rayfold
