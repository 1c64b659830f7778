#include "rayfold/exr.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "api/convert.h"
#include "api/scene_state.h"
#include "fold/fold.h"
#include "output/channels.h"
#include "output/image_output.h"
#include "rayfold/errors.h"
#include "rayfold/version.h"

namespace rayfold {
namespace {

// Every plane's size must be the image's when g says it has the plane, 0
// when not.
void check_planes(const GBuffer& g, const char* call) {
  for (const core::PlaneSpec& p : core::plane_specs()) {
    const size_t size = p.floats ? (g.*p.floats).size() : (g.*p.ids).size();
    const size_t want = (g.channels & p.bit) ? p.components * static_cast<size_t>(g.width) * g.height : 0;
    if (size != want)
      throw InputError("", std::string(call) + ": the G-buffer's " + p.name +
                               (p.floats == &GBuffer::uv ? " (uv)" : "") + " plane holds " + std::to_string(size) +
                               " values, not the " + std::to_string(want) + " its size " + std::to_string(g.width) +
                               "x" + std::to_string(g.height) + " and channels say");
  }
}

}  // namespace

ExrCompression exr_compression(const std::string& name) { return core::parse_exr_compression(name); }

namespace {

// The preview's input: g's normals and ids as the 32-byte hits the PNG
// writer takes.
std::vector<rf_pixel_hit> preview_hits(const GBuffer& g) {
  check_planes(g, "write_png");
  const size_t n = static_cast<size_t>(g.width) * g.height;
  std::vector<rf_pixel_hit> hits(n);
  for (size_t i = 0; i < n; ++i) {
    rf_pixel_hit& h = hits[i];
    h = {};
    h.nx = g.normal[3 * i];
    h.ny = g.normal[3 * i + 1];
    h.nz = g.normal[3 * i + 2];
    h.instance = g.instance_id[i];
  }
  return hits;
}

}  // namespace

namespace {

// A file in a folder that does not exist is the caller's slip, said as one
// (it read as a failure of the machine: "cannot write the EXR file: No such
// file or directory"). The CLI makes missing folders; the library does not.
void check_folder(const std::string& path, const char* call) {
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  std::error_code ignored;
  if (!folder.empty() && !std::filesystem::is_directory(folder, ignored))
    throw InputError(path, std::string(call) + ": its folder " + folder.string() +
                               " does not exist or is not a folder (" + call + " makes no folders)");
}

}  // namespace

void write_exr(const std::string& path, const GBuffer& g, const Camera& camera, const Scene& scene,
               ExrCompression compression, unsigned channels) {
  // An OpenEXR file under another name (x.png) is a mistake to name, not to write.
  std::string extension = path.size() >= 4 ? path.substr(path.size() - 4) : "";
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (extension != ".exr") throw InputError(path, "write_exr writes OpenEXR: name the file .exr");
  check_folder(path, "write_exr");
  if (g.width != camera.width() || g.height != camera.height())
    throw InputError("", "write_exr: the G-buffer is " + std::to_string(g.width) + "x" + std::to_string(g.height) +
                             ", its camera " + std::to_string(camera.width()) + "x" + std::to_string(camera.height()));
  if ((g.channels & channels) == 0)
    throw InputError("", "write_exr: channels " + std::to_string(channels) +
                             " name none of the G-buffer's planes (it has " + std::to_string(g.channels) + ")");
  check_planes(g, "write_exr");
  const detail::SceneState& s = *scene.state();
  // The header names the planes' ids by this scene's instances and labels:
  // ids past them say it is not the scene the view was rendered from (an
  // easy slip in a loop over scenes, which wrote another scene's names).
  auto check_ids = [&](const std::vector<uint32_t>& ids, size_t count, const char* plane, const char* what) {
    uint32_t largest = 0;
    bool any = false;
    for (uint32_t id : ids)
      if (id != kMiss) {
        largest = std::max(largest, id);
        any = true;
      }
    if (any && largest >= count)
      throw InputError("", std::string("write_exr: the G-buffer's ") + plane + " holds " + std::to_string(largest) +
                               ", but the scene has " + std::to_string(count) + " " + what + (count == 1 ? "" : "s") +
                               ": pass the scene the view was rendered from");
  };
  check_ids(g.instance_id, s.scene.instances.size(), "instance_id", "instance");
  // The labels a render read are in the scene's table; label 0 (none) always is.
  check_ids(g.label, std::max<size_t>(1, s.scene.labels.size()), "label", "label");
  core::ExrMetadata metadata =
      core::view_metadata(camera.core(), s.scene, s.path, core::fold_name(g.fold), g.depth_kind == Depth::planar,
                          g.exact_depth, RAYFOLD_VERSION_STRING);
  if (std::isfinite(g.time)) {
    char seconds[32];
    std::snprintf(seconds, sizeof seconds, "%.17g", g.time);  // read back to the same double
    metadata.strings.emplace_back("time", seconds);
  }
  core::write_exr(path, g, g.channels & channels, &metadata, compression);
}

void write_png(const std::string& path, const GBuffer& g) {
  if ((g.channels & (kNormal | kInstanceId)) != (kNormal | kInstanceId))
    throw InputError("",
                     "write_png: the preview shades normals and leaves misses black: the G-buffer needs its "
                     "normal and instance_id planes (it has channels " +
                         std::to_string(g.channels) + ")");
  check_folder(path, "write_png");
  core::write_png(path, preview_hits(g), g.width, g.height);
}

ExrHeader read_exr_header(const std::string& path) {
  ExrHeader h;
  const core::ExrMetadata m = core::read_exr_metadata(path, &h.width, &h.height);
  h.instance_names = m.instance_names;
  h.labels = m.labels;
  for (const auto& [name, value] : m.strings) {
    if (name == "fold") h.fold = value;
    if (name == "scene") h.scene = value;
    if (name == "version") h.version = value;
    if (name == "time") h.time = std::strtod(value.c_str(), nullptr);
    // Files from before rayfold:depthKind say it in words only.
    if (name == "depthKind" ? value == "planar" : name == "depth" && value.rfind("Z is the depth along", 0) == 0)
      h.depth_kind = Depth::planar;
  }
  if (m.view) {
    const core::ExrMetadata::View& v = *m.view;
    if (v.orthographic) {
      const glm::dvec3 eye(v.world_from_camera[3]), forward(-v.world_from_camera[2]), up(v.world_from_camera[1]);
      const glm::dvec3 target = eye + forward;
      h.camera = Camera::orthographic({eye.x, eye.y, eye.z}, {target.x, target.y, target.z}, {up.x, up.y, up.z},
                                      0.5 * h.height / v.fy, h.width, h.height);
    } else {
      h.camera = Camera::from_matrix(detail::to_matrix(v.world_from_camera), Intrinsics{v.fx, v.fy, v.cx, v.cy},
                                     h.width, h.height, CameraConvention::opengl);
    }
  }
  return h;
}

GBuffer read_exr(const std::string& path) {
  GBuffer g = core::read_exr_planes(path);
  if (g.channels & kInstanceId)
    for (uint32_t id : g.instance_id) g.hits += id != RF_INVALID;
  return g;
}

}  // namespace rayfold
