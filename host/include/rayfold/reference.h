// The double-precision ground truth of a view: what rayfold-peers and the
// benches measure every tracer's accuracy against (rayfold's, Embree's,
// Mitsuba's, Open3D's).
#pragma once

#include <cstdint>
#include <vector>

#include "rayfold/camera.h"
#include "rayfold/scene.h"

namespace rayfold {

struct ReferenceImage {
  int width = 0, height = 0;
  // Distance from the ray's origin (the eye, or an orthographic camera's
  // plane) along each pixel's exact ray (the camera model in double, not the
  // float ray a render traces) to the closest hit of the watertight triangle
  // test evaluated in double; +inf on a miss. The measure of a GBuffer's
  // distance depth. height * width, rows from the top.
  std::vector<double> depth;
  std::vector<uint32_t> instance_id;   // as GBuffer's: Scene instance index, kMiss on a miss
  std::vector<uint32_t> primitive_id;  // triangle index within the mesh, kMiss on a miss
};

// Traces every pixel of camera in double through the scene's trees (built
// now if the scene changed since they were) against the geometry as the
// scene states it: each mesh's float vertices through its instance's
// transform without rounding (the trees hold them scaled by powers of two,
// exactly), so that a tracer fed rounded world-space triangles (Embree's
// flat scene, Scene.world_triangles) has that rounding counted. For
// measuring accuracy, not for rendering (no vectors, tens of times slower
// than a render). Ties go to the lower (instance, primitive), as in
// rayfold's tracers. threads 0: all cores.
ReferenceImage render_reference(const Scene& scene, const Camera& camera, unsigned threads = 0);

}  // namespace rayfold
