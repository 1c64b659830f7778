// The options of `rayfold render`, as parsed.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <glm/vec3.hpp>

#include "rayfold/gbuffer.h"
#include "cli/commands/common.h"
#include "pipeline/pipeline.h"
#include "scene/gltf_loader.h"

namespace rayfold::core::commands {

struct RenderArgs {
  std::string scene = default_scene();
  int width = 1280, height = 720;
  std::optional<glm::dvec3> eye, look_at, up;
  std::optional<double> vfov, ortho;
  bool size_given = false;
  std::string cameras;           // --cameras FILE.json: one render per view (a camera list or transforms.json)
  std::string colmap;            // --colmap DIR: one render per image of a COLMAP text model
  unsigned channels = rayfold::kAllChannels;  // --channels: the EXR channels written (rayfold::Channels)
  rayfold::ExrCompression exr_compression = rayfold::ExrCompression::zip;  // --exr-compression
  std::optional<double> stereo;  // --stereo B: a left and a right view
  int align = 0;                 // --align N: views per pass; 0 = all (as many as a pass holds), -1 = auto
  bool fold_auto = false;        // --fold auto
  bool fold_given = false;       // --fold named at all
  double shift_x = 0.0, shift_y = 0.0;
  PipelineOptions renderer;
  FrameOptions frame;
  int frames = 1;
  double fps = 30.0;  // --animate on an animated file: frame f at --time + f / fps
  std::string exr, png, stats, ids;
  bool quiet = false;
  std::vector<std::string> load_warnings;  // the loader's, for --stats (filled once loaded)
  bool verbose = false;
  bool compare = false;
  LoadOptions load;
};

}  // namespace rayfold::core::commands
