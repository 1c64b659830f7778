// The pinhole camera: camera space has the eye at the origin, looks down -z,
// +x right, +y up. It is a rigid transform of world space, so distances agree.
#pragma once

#include <array>

#include "device_layout.h"
#include "scene/scene.h"
#include "scene/transform.h"

namespace rayfold::core {

struct Camera {
  Xform world_from_camera{1.0};
  Xform camera_from_world{1.0};
  int width = 0, height = 0;
  double vfov_degrees = 60.0;
  rf_camera params{};  // how the device turns pixels into rays
  // The exact values params rounds to float (params.scale_x, ..., frac_y):
  // the double reference traces these.
  double scale_x = 0.0, scale_y = 0.0, frac_x = 0.0, frac_y = 0.0;
};

// Pinhole intrinsics in pixels, with pixel (x, y)'s centre at (x + 0.5,
// y + 0.5) from the image's top-left corner, +y down.
struct Intrinsics {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
};

// Throws InputError for a degenerate view (eye == look_at, up parallel to the
// view direction, fov outside (0, 180), non-positive or too large sizes).
// shift_x, shift_y move the image window (an off-centre principal point) in
// units of half the image width and height; they are rounded to whole half
// pixels so that mirror partners keep exactly negated rays.
Camera make_camera(const CameraSpec& spec, int width, int height, double shift_x = 0.0, double shift_y = 0.0);

// A camera from a rigid world_from_camera (camera space: +x right, +y up,
// looking down -z) and pinhole intrinsics. A principal point on the
// half-pixel grid keeps mirror partners exact (frac_x, frac_y are 0); one off
// it cannot fold along that axis (can_fold_columns, can_fold_rows). Throws
// InputError for a transform that is not rigid or not finite, focal lengths
// that are not positive and finite, or a principal point more than 100
// images off centre.
Camera make_camera(const Xform& world_from_camera, const Intrinsics& k, int width, int height);

// Whether the principal point lets the fold pair columns (mirror about the
// vertical plane) or rows. The exact value is asked too: the exact depth
// (kernels/rf_depth.h) gives mirror partners one ray length, which holds
// where the exact ray has no offset along the folded axis.
inline bool can_fold_columns(const Camera& c) { return c.params.frac_x == 0.0f && c.frac_x == 0.0; }
inline bool can_fold_rows(const Camera& c) { return c.params.frac_y == 0.0f && c.frac_y == 0.0; }

// The camera's intrinsics (whatever made it), pixel centres at +0.5.
Intrinsics intrinsics(const Camera& camera);

// Pixel (x, y)'s camera-space ray direction and origin in double, the exact
// values the device's floats round: from the eye (the origin) for a
// perspective camera, from the image plane along -z for an orthographic one.
glm::dvec3 exact_direction(const Camera& camera, int x, int y);
glm::dvec3 exact_origin(const Camera& camera, int x, int y);
inline bool is_orthographic(const Camera& c) { return c.params.ortho != 0; }

// The angle between neighbouring pixels' rays at the image centre, radians.
double pixel_angle(const Camera& camera);

// Below this pixel angle (2^-20 radians: a 0.04-degree field of view over
// 720 rows) float positions, resolved to about 2^-24 of their distance
// from the eye in every tracer, stop resolving pixels: geometry seen through
// such a view is misplaced by a sixteenth of a pixel or more, and from 2^-24
// on lost altogether (docs/exactness.md, measured by rayfold-limits).
constexpr double kFinestPixelAngle = 0x1p-20;

// A parallel-axis stereo pair around `centre`: eye and look-at moved
// baseline / 2 to the left (first) and right along the camera's right
// vector, so both look the same way. Each eye renders as that spec alone.
std::array<CameraSpec, 2> stereo_specs(const CameraSpec& centre, double baseline);

// A view of the whole scene from its +z side, slightly above, as a default.
CameraSpec frame_bounds(const Aabb& world_bounds, double vfov_degrees = 60.0);

}  // namespace rayfold::core
