#include "scene/gltf_loader.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <tuple>

#include <tiny_gltf.h>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <nlohmann/json.hpp>

#include "scene/gltf_decompress.h"
#include "util/errors.h"

#include "scene/gltf/loader.h"

namespace rayfold::core {

using gltf::Loader;

struct GltfFile::Impl {
  std::vector<std::string> warnings;
  Loader loader;
  double end = NAN;
  Impl(const std::string& path, const LoadOptions& options) : loader(path, &warnings, options) {}
};

GltfFile::GltfFile(const std::string& path, const LoadOptions& options)
    : impl_(std::make_unique<Impl>(path, options)), path_(path) {
  impl_->loader.open();
  impl_->end = impl_->loader.animation_end();
  impl_->loader.cache_meshes(!std::isnan(impl_->end));
}

GltfFile::~GltfFile() = default;

Scene GltfFile::scene_at(double time) {
  Scene scene = impl_->loader.build(time);
  check_world_range(scene, path_);
  return scene;
}

void GltfFile::set_attributes(unsigned attributes) { impl_->loader.set_attributes(attributes); }
unsigned GltfFile::attributes() const { return impl_->loader.attributes(); }

bool GltfFile::animated() const { return !std::isnan(impl_->end); }
double GltfFile::animation_end() const { return std::isnan(impl_->end) ? 0.0 : impl_->end; }
const std::vector<std::string>& GltfFile::warnings() const { return impl_->warnings; }

Scene load_gltf(const std::string& path, std::vector<std::string>* warnings, const LoadOptions& options) {
  GltfFile file(path, options);
  Scene scene = file.scene_at(options.time);
  if (warnings) warnings->insert(warnings->end(), file.warnings().begin(), file.warnings().end());
  return scene;
}

bool apply_pose(Scene& scene, Scene&& posed, std::vector<uint32_t>* moved) {
  if (!same_geometry(scene, posed)) {
    scene = std::move(posed);
    return true;
  }
  for (size_t i = 0; i < scene.instances.size(); ++i)
    if (posed.instances[i].world_from_object != scene.instances[i].world_from_object) {
      scene.instances[i].world_from_object = posed.instances[i].world_from_object;
      moved->push_back(static_cast<uint32_t>(i));
    }
  return false;
}

bool same_geometry(const Scene& a, const Scene& b) {
  if (a.meshes.size() != b.meshes.size() || a.instances.size() != b.instances.size()) return false;
  for (size_t i = 0; i < a.instances.size(); ++i)
    if (a.instances[i].mesh != b.instances[i].mesh) return false;
  for (size_t m = 0; m < a.meshes.size(); ++m)
    if (a.meshes[m].positions != b.meshes[m].positions || a.meshes[m].indices != b.meshes[m].indices ||
        a.meshes[m].attributes.normals != b.meshes[m].attributes.normals ||
        a.meshes[m].attributes.tangents != b.meshes[m].attributes.tangents)
      return false;
  return true;
}

}  // namespace rayfold::core
