// The pinhole camera: camera space has the eye at the origin, looks down -z,
// +x right, +y up. It is a rigid transform of world space, so distances agree.
#pragma once

#include "device_layout.h"
#include "scene/scene.h"
#include "scene/transform.h"

namespace rayfold {

struct Camera {
  Xform world_from_camera{1.0};
  Xform camera_from_world{1.0};
  int width = 0, height = 0;
  double vfov_degrees = 60.0;
  rf_camera params{};  // how the device turns pixels into rays
};

// Throws InputError for a degenerate view (eye == look_at, up parallel to the
// view direction, fov outside (0, 180), non-positive or too large sizes).
// shift_x, shift_y move the image window (an off-centre principal point) in
// units of half the image width and height; they are rounded to whole half
// pixels so that mirror partners keep exactly negated rays.
Camera make_camera(const CameraSpec& spec, int width, int height, double shift_x = 0.0, double shift_y = 0.0);

// The angle between neighbouring pixels' rays at the image centre, radians.
double pixel_angle(const Camera& camera);

// Below this pixel angle (2^-20 radians: a 0.04-degree field of view over
// 720 rows) float positions, resolved to about 2^-24 of their distance
// from the eye in every tracer, stop resolving pixels: geometry seen through
// such a view is misplaced by a sixteenth of a pixel or more, and from 2^-24
// on lost altogether (docs/exactness.md, measured by rayfold-limits).
constexpr double kFinestPixelAngle = 0x1p-20;

// A view of the whole scene from its +z side, slightly above, as a default.
CameraSpec frame_bounds(const Aabb& world_bounds, double vfov_degrees = 60.0);

}  // namespace rayfold
