// What `rayfold render` writes besides the images' pixels: the EXR's
// metadata, --stats and --ids, the --compare table, and output names.
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "cli/camera_list.h"
#include "cli/commands/render_args.h"
#include "output/image_output.h"

namespace rayfold::core::commands {

// The EXR's record of the view and the instances (image_output.h).
ExrMetadata exr_metadata(const Camera& camera, const Scene& scene, const RenderArgs& args);

// The view as --stats and --ids record it: pose (OpenGL axes, row-major),
// intrinsics, eye.
nlohmann::json camera_json(const Camera& camera);

// --ids: what each InstanceID of the outputs is in the file.
void write_ids(const std::string& path, const RenderArgs& args, const Scene& scene);

// The pass of a camera list that traced a view, with the views beside it.
struct PassInfo {
  size_t index = 0;
  size_t views = 1;
};

// --stats: one view's figures. A view of a camera list (`pass` given) was
// traced with the others of its pass, so its times are the pass's.
void write_stats(const std::string& path, const RenderArgs& args, const Scene& scene, const Camera& camera,
                 const Pipeline& renderer, const RenderResult& result, double load_ms,
                 std::optional<PassInfo> pass = std::nullopt);

// The folded and unfolded renders of one view side by side.
void print_comparison(const RenderResult& none, const RenderResult& folded, Fold fold);

// An output name with one frame field (%d, %04d, ...): the name of frame f.
// Returns the name unchanged when it has no field; a second field or any
// other % is a usage error.
std::string frame_name(const std::string& option, const std::string& name, int frame, bool* has_field);

// The output of one view of a camera list or stereo pair (see render --help).
std::string view_output(const std::string& option, const std::string& name, const cli::View& v, bool stereo,
                        size_t count);

}  // namespace rayfold::core::commands
