// The first bytes of a rayfold scene file (bvh/scene_file.h: a scene with its
// trees, Scene.save): at the scene's level, so that the glTF reader can tell
// such a file from glTF and say so without reaching up into the trees.
#pragma once

#include <cstddef>
#include <cstring>

namespace rayfold::core {

inline constexpr char kSceneFileMagic[16] = "rayfold-scene\n";  // and two NULs

// Whether bytes start as scene bytes do (the magic), to tell them from glTF.
inline bool is_scene_file(const char* bytes, size_t size) {
  return size >= sizeof(kSceneFileMagic) && std::memcmp(bytes, kSceneFileMagic, sizeof(kSceneFileMagic)) == 0;
}

}  // namespace rayfold::core
