// Which views trace together: alignment (frame.h) needs the same rays, so a
// list of views splits into passes of alignable views, each within the group
// limit and the size asked for.
#pragma once

#include <cstddef>
#include <vector>

#include "bvh/scene_data.h"
#include "fold/fold.h"
#include "scene/camera.h"

namespace rayfold::core {

// The views' indices in passes: each pass holds views that can_align, at
// most `align` of them and at most max_pass_views of their fold (restricted
// per camera as the renderer does), in list order; passes are ordered by
// their first view. align = 1 traces every view alone.
std::vector<std::vector<size_t>> plan_passes(const SceneData& data, const std::vector<Camera>& views, int align,
                                             Fold fold);

}  // namespace rayfold::core
