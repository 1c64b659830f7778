#include "rayfold/reference.h"

#include "api/scene_state.h"
#include "reference/double_reference.h"
#include "scene/camera.h"

namespace rayfold {

ReferenceImage render_reference(const Scene& scene, const Camera& camera, unsigned threads) {
  detail::SceneState& s = *scene.state();
  const std::shared_ptr<const core::SceneData> trees = detail::current_trees(s);
  const std::vector<core::ReferenceHit> hits = core::trace_double_reference(s.scene, *trees, camera.core(), threads);
  ReferenceImage out;
  out.width = camera.width();
  out.height = camera.height();
  out.depth.reserve(hits.size());
  out.instance_id.reserve(hits.size());
  out.primitive_id.reserve(hits.size());
  for (const core::ReferenceHit& h : hits) {
    out.depth.push_back(h.distance);
    out.instance_id.push_back(h.instance);
    out.primitive_id.push_back(h.primitive);
  }
  return out;
}

}  // namespace rayfold
