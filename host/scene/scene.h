// The scene model: what hit info needs, and what a render's channels read.
// Meshes hold positions and triangle indices, and the attributes a render
// asked for (scene/attributes.h); instances place a mesh in the world.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "scene/aabb.h"
#include "scene/alpha_mask.h"
#include "scene/attributes.h"
#include "scene/materials.h"
#include "scene/transform.h"

namespace rayfold::core {

struct Mesh {
  std::string name;
  std::vector<glm::vec3> positions;
  std::vector<uint32_t> indices;  // three per triangle, in the file's winding
  MeshAttributes attributes;      // those loaded (LoadOptions::attributes)
  // Per triangle where a primitive's material is alphaMode MASK (all of
  // the mesh's triangles then, the others always kept); empty otherwise.
  std::vector<AlphaTriangle> alpha;
  size_t triangle_count() const { return indices.size() / 3; }
};

// Whether a mesh has a masked triangle: what the trace's tables
// (bvh/alpha_tables.h) and RF_ALPHA kernels are made for.
inline bool has_alpha_masks(const std::vector<Mesh>& meshes) {
  for (const Mesh& m : meshes)
    if (any_masked(m.alpha)) return true;
  return false;
}

struct Instance {
  uint32_t mesh = 0;
  Xform world_from_object{1.0};
  std::string name;  // the glTF node's name, "node N" when it has none
  int node = -1;     // the glTF node it comes from; -1 for one built in memory
  uint32_t label = 0;  // index into Scene::labels (kAttributeLabel); 0: none
};

// A camera; +y of the image is `up` projected onto the view plane.
// Perspective from the eye with a vertical field of view, or orthographic:
// parallel rays from the plane through the eye, the image ymag world units
// above and below the axis (square pixels set the width).
struct CameraSpec {
  glm::dvec3 eye{0.0, 0.0, 0.0};
  glm::dvec3 look_at{0.0, 0.0, -1.0};
  glm::dvec3 up{0.0, 1.0, 0.0};
  double vfov_degrees = 60.0;
  bool orthographic = false;
  double ymag = 1.0;  // orthographic: half the view's height, world units
};

// The largest world-space coordinate rayfold accepts (2^126, about 8.5e37):
// every distance between two such points, and so every depth, is a finite
// float, and the trace space of any view stays inside the float range.
constexpr double kMaxWorldCoordinate = 0x1p126;

struct Scene {
  std::vector<Mesh> meshes;
  std::vector<Instance> instances;
  // Read when a render asks (scene/attributes.h): every glTF material, by
  // its index (kAttributeMaterialData), the images their textures read,
  // and the distinct labels of the instances' nodes (kAttributeLabel; the
  // first is always "", no label).
  std::vector<Material> materials;
  std::vector<std::shared_ptr<const TextureImage>> images;
  std::vector<std::string> labels;
  std::vector<AlphaImage> alpha_images;  // the masked materials' base colour textures (Mesh::alpha)
  std::optional<CameraSpec> camera;  // the chosen camera (LoadOptions), by default the file's first

  // What the file holds besides the scene shown, for `rayfold info`.
  struct FileCamera {
    std::string name;         // the node's name
    int node = -1;            // the node that places it
    bool perspective = true;  // false: orthographic (spec.orthographic)
    CameraSpec spec;          // eye, look-at, up; vertical field of view or ymag
  };
  std::vector<FileCamera> cameras;       // every camera node of the shown scene, in node order
  std::vector<std::string> scene_names;  // every scene of the file ("" when unnamed)
  int scene_index = -1;                  // the one shown; -1 when the file has no scenes

  size_t triangle_count() const;         // over instances, as rendered
  size_t unique_triangle_count() const;  // over meshes, as stored
  Aabb mesh_bounds(uint32_t mesh) const;
  Aabb world_bounds() const;
};

// The most instances a scene may have: 2^32 / RF_GROUP_LIMIT.
constexpr size_t kMaxInstances = size_t{1} << 27;

// Throws InputError(file, ...) naming the first instance whose geometry
// reaches beyond kMaxWorldCoordinate (or is not finite) in world space, or
// when the scene has more than kMaxInstances instances.
void check_world_range(const Scene& scene, const std::string& file);

}  // namespace rayfold::core
