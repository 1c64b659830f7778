// A scene with its prebuilt trees as bytes (Scene::save, Scene::to_bytes):
// a worker that loads them renders at once, with the very trees the writer
// built, instead of building its own.
//
// Layout, in the writing machine's byte order (a reader whose order or
// device structs differ refuses the bytes):
//   bytes 0..15   "rayfold-scene\n\0\0" (magic)
//   u32           format version (kSceneFormat)
//   u32           sizeof rf_node, rf_tri, rf_wide_node, rf_normal_xform, one byte each
//   u64           payload length P
//   P bytes       payload: the rayfold version string, then the scene (meshes
//                 with their alpha masks, instances, cameras, scene names,
//                 alpha images; the source path and load warnings) and its
//                 SceneData (bvh/scene_data.h, alpha tables last), each vector
//                 as a u64 count then its items, each string as a u64 length
//                 then its bytes
//   u64           FNV-1a 64 of the payload, over 8-byte words (native
//                 order) and then its last bytes one by one
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "bvh/scene_data.h"
#include "scene/scene.h"
#include "scene/scene_file_signature.h"  // is_scene_file: the bytes' first check

namespace rayfold::core {

// 2: merged trees (rf_tri::inst, BlasSet::traced_by, instance_roots, merged).
// 3: alpha masks (Mesh::alpha, Scene::alpha_images, SceneData::alpha).
constexpr unsigned kSceneFormat = 3;

struct SceneFile {
  Scene scene;
  SceneData data;
  std::string source;                 // the file the scene was loaded from ("" when built in memory)
  std::vector<std::string> warnings;  // what loading that file reported
};

std::string scene_file_bytes(const SceneFile& file, const std::string& rayfold_version);

// Throws InputError(what, ...) for bytes that are cut short, damaged (the
// checksum), of another format or rayfold version, or another machine's
// layout, saying which.
SceneFile read_scene_file(const char* bytes, size_t size, const std::string& what,
                          const std::string& rayfold_version);

}  // namespace rayfold::core
