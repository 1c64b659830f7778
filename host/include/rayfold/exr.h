// G-buffers as OpenEXR files (and PNG previews), the format `rayfold render -o` writes
// (docs/formats.md: channels Z, N.X, N.Y, N.Z, U, V, InstanceID,
// PrimitiveID, and the camera and instance names in the header).
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "rayfold/camera.h"
#include "rayfold/gbuffer.h"
#include "rayfold/scene.h"

namespace rayfold {

// Writes the planes g has (g.channels) as the CLI writes a view, with
// camera's pose and intrinsics and scene's instance names in the header.
// The file appears whole or not at all (a temporary renamed into place,
// removed on failure or on SIGINT/SIGTERM/SIGHUP in the CLI). Throws
// InputError for a G-buffer whose planes do not match its size or camera,
// whose instance or label ids the scene does not have (another scene), a
// path not named .exr or in a folder that does not exist; RuntimeFailure naming the file when it cannot
// be written. compression:
// OpenEXR's lossless methods (ExrCompression), ZIP by default. channels
// (Channels): g's planes that it also names are written (the CLI's
// --channels); InputError when it names none of them.
void write_exr(const std::string& path, const GBuffer& g, const Camera& camera, const Scene& scene,
               ExrCompression compression = ExrCompression::zip, unsigned channels = kAnyChannel);

// A preview of g as the CLI's --png writes it: normals mapped to colour
// ((n + 1) / 2, 8 bits), misses black. Needs g's normal and instance_id
// planes (InputError otherwise, or for a folder that does not exist); whole
// or not at all, RuntimeFailure naming the file when it cannot be written.
void write_png(const std::string& path, const GBuffer& g);
// "none", "rle", "zips", "zip" or "piz"; InputError otherwise (a lossy
// method named as such).
ExrCompression exr_compression(const std::string& name);

// Reads what write_exr or the CLI wrote: the planes the file has
// (channels), bit for bit. InputError naming the file otherwise.
GBuffer read_exr(const std::string& path);

// The header of an EXR write_exr or the CLI wrote: what turns its planes
// into points and names.
struct ExrHeader {
  int width = 0, height = 0;
  std::optional<Camera> camera;             // the view's camera, from its pose and intrinsics; none in another EXR
  Depth depth_kind = Depth::distance;       // what Z measures
  std::vector<std::string> instance_names;  // by InstanceID
  std::vector<std::string> labels;          // by Label (Scene::labels); empty when not written
  std::string fold, scene, version;
  double time = std::numeric_limits<double>::quiet_NaN();  // rayfold:time (GBuffer::time); NaN when not written
};
// InputError naming the file when it cannot be read.
ExrHeader read_exr_header(const std::string& path);

}  // namespace rayfold
