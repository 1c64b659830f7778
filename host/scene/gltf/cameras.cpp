// The file's cameras and the one chosen.
#include "scene/gltf/loader.h"

namespace rayfold::core::gltf {

void Loader::add_camera(int ni, const Xform& world_from_node) {
  const int ci = model_.nodes[ni].camera;
  if (static_cast<size_t>(ci) >= model_.cameras.size())
    fail("node " + std::to_string(ni) + " refers to camera " + std::to_string(ci) + ", which does not exist");
  const tinygltf::Camera& c = model_.cameras[ci];
  Scene::FileCamera fc;
  fc.name = node_name(ni);
  fc.node = ni;
  fc.perspective = c.type == "perspective";
  fc.spec.eye = transform_point(world_from_node, glm::dvec3(0.0));
  fc.spec.look_at = transform_point(world_from_node, glm::dvec3(0.0, 0.0, -1.0));
  fc.spec.up = glm::dvec3(world_from_node * glm::dvec4(0.0, 1.0, 0.0, 0.0));
  if (fc.perspective) {
    fc.spec.vfov_degrees = c.perspective.yfov * 180.0 / M_PI;
    if (!(fc.spec.vfov_degrees > 0.0 && fc.spec.vfov_degrees < 180.0)) {
      warn("camera " + std::to_string(ci) + " has a vertical field of view outside (0, 180) degrees; ignored");
      return;
    }
  } else if (c.type == "orthographic") {
    // ymag: half the view's height in world units (square pixels set the
    // width from the image's; xmag is not needed).
    fc.spec.orthographic = true;
    fc.spec.ymag = std::fabs(c.orthographic.ymag);
    if (!(fc.spec.ymag > 0.0 && std::isfinite(fc.spec.ymag))) {
      warn("camera " + std::to_string(ci) + " has an orthographic ymag that is not positive; ignored");
      return;
    }
  } else {
    warn("camera " + std::to_string(ci) + " has the unknown type '" + c.type + "'; ignored");
    return;
  }
  scene_.cameras.push_back(fc);
}

void Loader::choose_camera() {
  const int asked = options_.camera;
  if (asked >= 0) {
    if (static_cast<size_t>(asked) >= scene_.cameras.size())
      fail("camera " + std::to_string(asked) + " does not exist (the scene shows " +
           std::to_string(scene_.cameras.size()) + " cameras)");
    scene_.camera = scene_.cameras[asked].spec;
    return;
  }
  if (!scene_.cameras.empty()) scene_.camera = scene_.cameras.front().spec;
}

}  // namespace rayfold::core::gltf
