// Views nobody chose: random cameras for the benchmarks, so that a speed or
// accuracy figure does not depend on the views the project happened to pick.
//
// The generator, given a scene and a seed (the same views on every machine):
//  - interior (the scene encloses its centre, see classify_scene): the eye
//    is uniform in the world bounds shrunk by 10% on each side, the view
//    looks at a point uniform in the bounds at least a tenth of the bounds'
//    diagonal away, +y up;
//  - object: the eye orbits the bounds' centre at 1.2 to 3 bounding-sphere
//    radii, azimuth uniform, elevation uniform in [-20, 70] degrees, and
//    looks at a point within a quarter radius of the centre, +y up;
//  - the vertical field of view is uniform in [40, 90] degrees.
// Each candidate is traced at 64x36 by the CPU reference and drawn again
// when it sees little geometry: fewer than half its pixels hit (a quarter
// for objects), or, in an interior, more than half its hits are of back
// faces (an eye inside a wall or under a floor). After 200 draws for one
// view the best candidate seen is kept, and the view says so.
// Random numbers: tools/splitmix.h, the same sequence on every machine.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "scene/scene.h"

namespace rayfold::core {

class Pipeline;

enum class ViewKind { automatic, interior, object };

// "auto", "interior", "object"; parse_view_kind throws UsageError otherwise.
const char* view_kind_name(ViewKind kind);
ViewKind parse_view_kind(const std::string& flag, const std::string& value);

struct RandomViews {
  ViewKind kind = ViewKind::object;  // the kind the views were drawn as (never automatic)
  std::vector<CameraSpec> cameras;
  std::vector<double> hit_fraction;  // per view, at the probe's resolution
  int redrawn = 0;                   // candidates rejected over all views
  int below_threshold = 0;           // views kept after 200 draws without meeting the threshold
};

// Interior when rays from the centre of the world bounds hit front faces in
// at least 60% of directions and rays from the centres of its eight octants
// in at least 50% (32 x 32 cube maps traced by `cpu`). Measured: the
// conference room and both atria 0.70 to 0.99 at the centre and 0.75 to 0.99
// at the octants; the sports car 0.84 at the centre (its cabin) but 0.44 at
// the octants; Lost Empire 0.998 and 0.42 (a walled town in open terrain,
// which the benchmarks name an interior themselves); the scanned objects
// 0.22 to 0.25 at the octants.
ViewKind classify_scene(const Scene& scene, Pipeline& cpu);

// `count` views of the scene from `seed`; kind automatic classifies first.
// `cpu` must be a CPU-reference renderer of this scene.
RandomViews random_views(const Scene& scene, Pipeline& cpu, int count, uint64_t seed,
                         ViewKind kind = ViewKind::automatic);

}  // namespace rayfold::core
