// Scene -> binary glTF (.glb): positions, indices, the instance transforms and
// the camera, nothing else. Used by the scene generator and by tests that
// need files.
#pragma once

#include <string>

#include "scene/scene.h"

namespace rayfold::core {

// Written atomically; throws InputError naming the file on failure.
void write_glb(const Scene& scene, const std::string& path);

}  // namespace rayfold::core
