#include "rayfold/exr.h"

#include <cstddef>

#include "api/convert.h"
#include "api/scene_state.h"
#include "fold/fold.h"
#include "rayfold/errors.h"
#include "rayfold/version.h"
#include "output/image_output.h"

namespace rayfold {
namespace {

// A plane's size must be the image's when g says it has the plane, 0 when not.
void check_plane(size_t size, size_t per_pixel, unsigned bit, const GBuffer& g, const char* name) {
  const size_t want = (g.channels & bit) ? per_pixel * static_cast<size_t>(g.width) * g.height : 0;
  if (size != want)
    throw InputError("", std::string("write_exr: the G-buffer's ") + name + " plane holds " + std::to_string(size) +
                             " values, not the " + std::to_string(want) + " its size " + std::to_string(g.width) +
                             "x" + std::to_string(g.height) + " and channels say");
}

}  // namespace

ExrCompression exr_compression(const std::string& name) { return core::parse_exr_compression(name); }

namespace {

// g's planes as the 32-byte hits the writers take; a plane g lacks reads as
// a miss's value (instance and primitive kMiss, the rest 0).
std::vector<rf_pixel_hit> hits_of(const GBuffer& g) {
  check_plane(g.depth.size(), 1, kDepth, g, "depth");
  check_plane(g.normal.size(), 3, kNormal, g, "normal");
  check_plane(g.uv.size(), 2, kUv, g, "uv");
  check_plane(g.instance_id.size(), 1, kInstanceId, g, "instance_id");
  check_plane(g.primitive_id.size(), 1, kPrimitiveId, g, "primitive_id");
  const size_t n = static_cast<size_t>(g.width) * g.height;
  std::vector<rf_pixel_hit> hits(n);
  for (size_t i = 0; i < n; ++i) {
    rf_pixel_hit& h = hits[i];
    h = {};
    if (g.channels & kDepth) h.z = g.depth[i];
    if (g.channels & kNormal) {
      h.nx = g.normal[3 * i];
      h.ny = g.normal[3 * i + 1];
      h.nz = g.normal[3 * i + 2];
    }
    if (g.channels & kUv) {
      h.u = g.uv[2 * i];
      h.v = g.uv[2 * i + 1];
    }
    h.instance = (g.channels & kInstanceId) ? g.instance_id[i] : RF_INVALID;
    h.primitive = (g.channels & kPrimitiveId) ? g.primitive_id[i] : RF_INVALID;
  }
  return hits;
}

}  // namespace

void write_exr(const std::string& path, const GBuffer& g, const Camera& camera, const Scene& scene,
               ExrCompression compression, unsigned channels) {
  if (g.width != camera.width() || g.height != camera.height())
    throw InputError("", "write_exr: the G-buffer is " + std::to_string(g.width) + "x" + std::to_string(g.height) +
                             ", its camera " + std::to_string(camera.width()) + "x" + std::to_string(camera.height()));
  if ((g.channels & channels) == 0)
    throw InputError("", "write_exr: channels " + std::to_string(channels) +
                             " name none of the G-buffer's planes (it has " + std::to_string(g.channels) + ")");
  const std::vector<rf_pixel_hit> hits = hits_of(g);
  const detail::SceneState& s = *scene.state();
  const core::ExrMetadata metadata =
      core::view_metadata(camera.core(), s.scene, s.path, core::fold_name(g.fold),
                          g.depth_kind == Depth::planar, g.exact_depth, RAYFOLD_VERSION_STRING);
  core::write_exr(path, hits, g.width, g.height, &metadata, g.channels & channels, compression);
}

void write_png(const std::string& path, const GBuffer& g) {
  if ((g.channels & (kNormal | kInstanceId)) != (kNormal | kInstanceId))
    throw InputError("",
                     "write_png: the preview shades normals and leaves misses black: the G-buffer needs its "
                     "normal and instance_id planes (it has channels " +
                         std::to_string(g.channels) + ")");
  core::write_png(path, hits_of(g), g.width, g.height);
}

GBuffer read_exr(const std::string& path) {
  GBuffer g;
  unsigned channels = 0;
  const std::vector<rf_pixel_hit> hits = core::read_exr(path, &g.width, &g.height, &channels);
  const size_t n = hits.size();
  g.channels = channels;
  if (channels & kDepth) g.depth.resize(n);
  if (channels & kNormal) g.normal.resize(3 * n);
  if (channels & kUv) g.uv.resize(2 * n);
  if (channels & kInstanceId) g.instance_id.resize(n);
  if (channels & kPrimitiveId) g.primitive_id.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const rf_pixel_hit& h = hits[i];
    if (channels & kDepth) g.depth[i] = h.z;
    if (channels & kNormal) {
      g.normal[3 * i] = h.nx;
      g.normal[3 * i + 1] = h.ny;
      g.normal[3 * i + 2] = h.nz;
    }
    if (channels & kUv) {
      g.uv[2 * i] = h.u;
      g.uv[2 * i + 1] = h.v;
    }
    if (channels & kInstanceId) g.instance_id[i] = h.instance;
    if (channels & kPrimitiveId) g.primitive_id[i] = h.primitive;
    g.hits += (channels & kInstanceId) && h.instance != RF_INVALID;
  }
  return g;
}

}  // namespace rayfold
