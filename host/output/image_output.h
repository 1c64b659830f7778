// Writing hit info: the OpenEXR G-buffer and a PNG preview of the normals.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <glm/mat4x4.hpp>

#include "device_layout.h"
#include "rayfold/gbuffer.h"
#include "scene/camera.h"
#include "scene/scene.h"
#include "util/span.h"

namespace rayfold::core {

// What an EXR records besides the pixels, so that depth can be turned back
// into positions and ids into the file's nodes.
struct ExrMetadata {
  struct View {
    glm::dmat4 world_from_camera{1.0};  // rigid; camera +x right, +y up, looking down -z
    double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;  // pixels, pixel centres at +0.5
    // Parallel rays along -z from the plane through the eye; fx, fy are then
    // pixels per world unit.
    bool orthographic = false;
  };
  std::optional<View> view;
  std::vector<std::string> instance_names;                   // by InstanceID
  std::vector<std::string> labels;                           // by Label (rayfold:labels); empty: not read
  std::vector<std::pair<std::string, std::string>> strings;  // more string attributes, named "rayfold:<first>"
};

// The metadata of one view's EXR, the same from the CLI and the API: the
// camera's pose and intrinsics, the scene's instance names, and the strings
// version, scene (a label: the file's path), fold (the one asked for) and
// what the depth (planar or not, exact or not) and ids mean.
ExrMetadata view_metadata(const Camera& camera, const Scene& scene, const std::string& scene_label,
                          const std::string& fold, bool planar_depth, bool exact_depth, const std::string& version);

// One part, channels Z, N.X, N.Y, N.Z, U, V (FLOAT), InstanceID, PrimitiveID
// (UINT). With metadata, the header also carries:
//   worldToCamera, worldToNDC   OpenEXR's standard attributes (M44f, Imath's
//                               row vectors: p' = p * M). Camera space is
//                               RenderMan's, as OpenEXR specifies: +x right,
//                               +y up, +z forward; NDC x and y run 0..1 from
//                               the image's top-left corner, NDC z is 1 / z
//                               (orthographic: NDC z is z).
//   rayfold:cameraToWorld       M44d, the same pose in double, OpenGL axes
//                               (-z forward), row vectors
//   rayfold:fx, fy, cx, cy      double, the intrinsics in pixels (per world
//                               unit for an orthographic camera)
//   rayfold:projection          "perspective" or "orthographic"
//   rayfold:instanceNames       string vector indexed by InstanceID
//   rayfold:<name>              each of metadata.strings
// Throws RuntimeFailure naming the file on failure; never leaves a partial file.
// channels (rayfold::Channels) picks the channels written: Z, N.X/N.Y/N.Z,
// U/V, InstanceID, PrimitiveID.
// compression: an OpenEXR lossless method (exr_compressions()): zip by
// default; none writes 3 to 4 times faster at 10 times the bytes, which
// pays where the disk is fast and a job writes many views.
void write_exr(const std::string& path, ConstSpan<rf_pixel_hit> hits, int width, int height,
               const ExrMetadata* metadata = nullptr, unsigned channels = kAllChannels,
               rayfold::ExrCompression compression = rayfold::ExrCompression::zip);
// The planes of g that `channels` names (each of the size g's width and
// height give), under the names of output/channels.h; otherwise as above.
void write_exr(const std::string& path, const GBuffer& g, unsigned channels, const ExrMetadata* metadata,
               rayfold::ExrCompression compression);
// Every plane of output/channels.h whose EXR channels the file has, bit for
// bit (g.channels says which); InputError naming the file on failure.
GBuffer read_exr_planes(const std::string& path);
// The header's rayfold metadata as view_metadata wrote it (strings without
// their "rayfold:" prefix), and the image's size; InputError naming the
// file on failure.
ExrMetadata read_exr_metadata(const std::string& path, int* width, int* height);
// The lossless methods by name ("none, rle, zips, zip, piz"), for messages.
const char* exr_compressions();
// "none", "rle", "zips", "zip" or "piz" as ExrCompression; InputError
// naming the lossless ones otherwise, and why a lossy one (b44, dwaa,
// pxr24, ...) is refused.
rayfold::ExrCompression parse_exr_compression(const std::string& name);


// Normals mapped to colour ((n + 1) / 2), misses black. RuntimeFailure
// naming the file on failure.
void write_png(const std::string& path, ConstSpan<rf_pixel_hit> hits, int width, int height);

// Reads back what write_exr wrote; InputError naming the file on failure.
// *channels (when given): the planes the file has (all of a plane's
// channels); the others read as 0.
std::vector<rf_pixel_hit> read_exr(const std::string& path, int* width, int* height, unsigned* channels = nullptr);

}  // namespace rayfold::core
