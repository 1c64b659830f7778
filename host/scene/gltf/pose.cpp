// One pose of the whole scene: the hierarchy walked from the chosen scene's
// roots, every instance, mesh and camera on the way.
#include "scene/gltf/loader.h"

namespace rayfold::core::gltf {

Scene Loader::build(double time) {
  scene_ = Scene{};
  mesh_slot_.clear();
  parent_.clear();
  model_.nodes = rest_nodes_;
  if (!std::isnan(time)) pose_at(time);
  std::vector<int> roots = root_nodes();
  // Depth-first over the hierarchy with an explicit stack; `on_path` finds
  // cycles, `visited` nodes reachable twice (a DAG is not a tree either).
  struct Item {
    int node;
    Xform world_from_parent;
    bool leaving;
  };
  std::vector<Item> stack;
  for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.push_back({*it, Xform(1.0), false});
  std::vector<char> on_path(model_.nodes.size(), 0), visited(model_.nodes.size(), 0);
  while (!stack.empty()) {
    Item item = stack.back();
    stack.pop_back();
    if (item.leaving) {
      on_path[item.node] = 0;
      continue;
    }
    const int ni = item.node;
    if (ni < 0 || static_cast<size_t>(ni) >= model_.nodes.size())
      fail("a node reference (" + std::to_string(ni) + ") is out of range");
    if (on_path[ni]) fail("node " + std::to_string(ni) + " is its own ancestor (a cycle in the node hierarchy)");
    if (visited[ni]) fail("node " + std::to_string(ni) + " has more than one parent");
    visited[ni] = 1;
    on_path[ni] = 1;
    const tinygltf::Node& node = model_.nodes[ni];
    const Xform world_from_node = item.world_from_parent * local_transform(ni);
    if (node.mesh >= 0)
      add_instance(ni, world_from_node);
    else if (node.mesh < -1)
      fail("node " + std::to_string(ni) + " has a negative mesh index");
    if (node.camera >= 0) add_camera(ni, world_from_node);
    stack.push_back({ni, Xform(1.0), true});
    for (auto it = node.children.rbegin(); it != node.children.rend(); ++it)
      stack.push_back({*it, world_from_node, false});
  }
  add_material_data();
  scene_.alpha_images = alpha_images_;
  choose_camera();
  if (scene_.triangle_count() == 0) warn("the scene has no triangles; every pixel will miss");
  flush_warnings();
  pending_.clear();
  return std::move(scene_);
}

}  // namespace rayfold::core::gltf
