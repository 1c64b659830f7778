// The double-float rays of exact depth (kernels/rf_depth.h): per view and
// scene instance, the pixel's exact ray in the instance's tree space.
#pragma once

#include "device_layout.h"
#include "scene/camera.h"
#include "scene/transform.h"

namespace rayfold::core {

// The rf_depth_xform of `camera`'s pixel rays taken into a space by
// space_from_trace (a tree_from_trace; the identity for the view's camera
// entry), trace space being camera space in units of 2^trace_exponent.
rf_depth_xform make_depth_xform(const Xform& space_from_trace, const Camera& camera, int trace_exponent);

}  // namespace rayfold::core
