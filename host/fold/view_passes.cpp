#include "fold/view_passes.h"

#include <algorithm>

#include "fold/frame.h"
#include "util/errors.h"

namespace rayfold::core {

std::vector<std::vector<size_t>> plan_passes(const SceneData& data, const std::vector<Camera>& views, int align,
                                             Fold fold) {
  RF_CHECK_GE(align, 1, "a pass holds at least one view");
  std::vector<std::vector<size_t>> passes;
  std::vector<size_t> open;  // per intrinsics, the pass still filling
  for (size_t i = 0; i < views.size(); ++i) {
    const Camera& c = views[i];
    const Fold traced = restrict_fold(fold, can_fold_columns(c), can_fold_rows(c));
    const size_t limit = static_cast<size_t>(std::min(align, max_pass_views(traced)));
    auto it =
        std::find_if(open.begin(), open.end(), [&](size_t p) { return can_align(data, views[passes[p].front()], c); });
    if (it != open.end() && passes[*it].size() < limit) {
      passes[*it].push_back(i);
      continue;
    }
    if (it != open.end()) open.erase(it);  // full: the next view of these intrinsics opens a new pass
    passes.push_back({i});
    open.push_back(passes.size() - 1);
  }
  return passes;
}

}  // namespace rayfold::core
