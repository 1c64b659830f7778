// The options of `rayfold render`, as parsed.
#pragma once

#include <optional>
#include <string>

#include "cli/commands/common.h"
#include "rayfold/rayfold.h"

namespace rayfold::core::commands {

struct RenderArgs {
  std::string scene = default_scene();
  int width = 1280, height = 720;
  std::optional<rayfold::Vec3> eye, look_at, up;
  std::optional<double> vfov, ortho;
  bool size_given = false;
  std::string cameras;           // --cameras FILE.json: one render per view (a camera list or transforms.json)
  std::string colmap;            // --colmap DIR: one render per image of a COLMAP text model
  unsigned channels = rayfold::kAllChannels;  // --channels: the EXR channels written (rayfold::Channels)
  rayfold::ExrCompression exr_compression = rayfold::ExrCompression::zip;  // --exr-compression
  std::optional<double> stereo;  // --stereo B: a left and a right view
  int align = 0;                 // --align N: views per pass; 0 = all (as many as a pass holds), -1 = auto
  rayfold::Fold fold = rayfold::Fold::none;
  bool fold_auto = false;        // --fold auto
  bool fold_given = false;       // --fold named at all
  double shift_x = 0.0, shift_y = 0.0;
  rayfold::RendererOptions options;
  rayfold::LoadOptions load;
  bool animate = false;
  int frames = 1;
  double fps = 30.0;  // --animate on an animated file: frame f at --time + f / fps
  std::string exr, png, stats, ids;
  bool quiet = false;
  bool verbose = false;
  bool compare = false;

  // The planes a render fills: the EXR's, and what the preview shades and
  // --compare compares.
  unsigned render_channels() const {
    if (compare) return channels | rayfold::kAllChannels;
    return channels | (png.empty() ? 0u : unsigned(rayfold::kNormal | rayfold::kInstanceId));
  }
};

}  // namespace rayfold::core::commands
