#include "frame.h"

#include <chrono>

#include "bvh_flatten.h"

namespace rayfold {
namespace {

double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace

SceneData prepare_scene(const Scene& scene, unsigned threads) {
  SceneData data;
  data.blas = build_blas_set(scene, BuildOptions{}, threads);
  const size_t n = scene.instances.size();
  data.object_from_world.resize(n);
  data.renderable.resize(n);
  data.normal_xforms.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const Instance& inst = scene.instances[i];
    // glTF allows a zero scale: such an instance is simply not there.
    const bool invertible = affine_inverse(inst.world_from_object, &data.object_from_world[i]);
    data.renderable[i] = invertible && data.blas.roots[inst.mesh] != RF_INVALID;
    if (invertible) normal_matrix_rows3x3(inst.world_from_object, data.normal_xforms[i].m);
    if (!invertible) data.hidden_instances++;
  }
  return data;
}

size_t max_tlas_nodes(const Scene& scene) { return 2 * RF_MAX_GROUPS * scene.instances.size() + 2; }

Frame build_frame(const Scene& scene, const SceneData& data, const Camera& camera, const FrameOptions& options) {
  Frame frame;
  frame.node_base = static_cast<uint32_t>(data.blas.nodes.size());

  auto t0 = std::chrono::steady_clock::now();
  const Frustum frustum(camera.params, full_region(camera.params));
  std::vector<Aabb> boxes;
  std::vector<rf_instance> candidates;
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    if (!data.renderable[i]) continue;
    frame.stats.candidates++;
    const Instance& inst = scene.instances[i];
    const Xform camera_from_object = camera.camera_from_world * inst.world_from_object;
    const Aabb box = transform_bounds_conservative(camera_from_object, data.blas.bounds[inst.mesh]);
    if (options.cull && !frustum.may_see(box)) continue;
    rf_instance out{};
    to_rows3x4(data.object_from_world[i] * camera.world_from_camera, out.object_from_camera);
    out.blas_root = data.blas.roots[inst.mesh];
    out.instance_id = static_cast<uint32_t>(i);
    out.group = 0;
    candidates.push_back(out);
    boxes.push_back(box);
  }
  frame.stats.kept = candidates.size();
  frame.stats.cull_ms = ms_since(t0);

  t0 = std::chrono::steady_clock::now();
  BuildOptions tlas_options;
  tlas_options.max_leaf_size = 4;
  tlas_options.intersection_cost = 2.0f;  // an instance costs a ray transform on top of its root test
  const BuildTree tree = build_sah(boxes, tlas_options);
  frame.instances.reserve(tree.order.size());
  std::vector<uint32_t> groups;
  groups.reserve(tree.order.size());
  for (uint32_t k : tree.order) {
    frame.instances.push_back(candidates[k]);
    groups.push_back(1u << candidates[k].group);
  }
  frame.tlas_root = flatten_bvh(tree, 0, &groups, frame.node_base, frame.tlas_nodes);
  frame.stats.tlas_ms = ms_since(t0);
  frame.stats.tlas_sah = tree.sah_cost;
  frame.stats.tlas_depth = tree.depth;
  return frame;
}

}  // namespace rayfold
