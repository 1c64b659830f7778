// Where a camera goes when nobody says where: outside an object, looking at
// the whole of it; inside a room, looking along it. Decided by tracing small
// probe images with the CPU reference over the scene's own trees, so the
// rule is the same on every machine and every backend.
#pragma once

#include <glm/vec3.hpp>

#include "scene/camera.h"
#include "scene/scene.h"

namespace rayfold::core {

class Pipeline;

enum class ViewKind { automatic, interior, object };

// What a probe image of a view saw: the share of its pixels that hit, and of
// those the share seen from the front (the world normal against the ray),
// and the median distance of the front hits (0 when none).
struct Probe {
  double hit_fraction = 0.0;
  double front_fraction = 0.0;
  double median_front_depth = 0.0;
};

// Traces the view at width x height with `cpu`, a CPU-reference pipeline of
// the scene.
Probe probe(Pipeline& cpu, const CameraSpec& spec, int width, int height);

// +y, or +z for a view that looks (nearly) straight up or down, where +y
// would be parallel to it.
glm::dvec3 up_for(const glm::dvec3& eye, const glm::dvec3& target);

// Interior when rays from the centre of the world bounds hit front faces in
// at least 60% of directions (or back faces: the centre is inside something
// solid, a pillar in the middle of a hall) and rays from the centres of its
// eight octants hit front faces in at least 50% (32 x 32 cube maps traced by
// `cpu`). Measured: the
// conference room and both atria 0.70 to 0.99 at the centre and 0.75 to 0.99
// at the octants; the sports car 0.84 at the centre (its cabin) but 0.44 at
// the octants; Lost Empire 0.998 and 0.42 (a walled town in open terrain);
// the scanned objects 0.22 to 0.25 at the octants.
ViewKind classify_scene(const Scene& scene, Pipeline& cpu);

struct AutoFrame {
  CameraSpec spec;
  ViewKind kind = ViewKind::object;
};

// The default view of a scene without a camera. An object: frame_bounds (the
// whole scene from its +z side, slightly above). An interior: from the
// centre of the bounds, or where that sees mostly back faces (inside a
// wall or a column) from the centre of an octant, looking horizontally in
// the one of eight directions that sees the most front faces furthest away
// (a view down the room's length, not into the nearest wall); +y up.
// `cpu` must be a CPU-reference pipeline of this scene.
AutoFrame auto_frame(const Scene& scene, Pipeline& cpu, double vfov_degrees = 60.0);

}  // namespace rayfold::core
