// What `rayfold render` writes besides the images' pixels: --stats and
// --ids, the --compare table, and output names.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/commands/render_args.h"

namespace rayfold::core::commands {

// The view as --stats records it: pose (OpenGL axes, row-major),
// intrinsics, eye.
nlohmann::json camera_json(const rayfold::Camera& camera);

// --ids: what each InstanceID of the outputs is in the file.
void write_ids(const std::string& path, const RenderArgs& args, const rayfold::Scene& scene);

// The pass of a camera list that traced a view, with the views beside it.
struct PassInfo {
  size_t index = 0;
  size_t views = 1;
};

// --stats: one view's figures; `times`: the stages' medians over `frames`
// frames. A view of a camera list (`pass` given) was traced with the
// others of its pass, so its times are the pass's.
void write_stats(const std::string& path, const RenderArgs& args, const rayfold::Scene& scene,
                 const rayfold::Camera& camera, const rayfold::Renderer& renderer, const rayfold::GBuffer& g,
                 const rayfold::StageTimes& times, size_t frames, double load_ms,
                 std::optional<PassInfo> pass = std::nullopt);

// Each stage's median over frames.
rayfold::StageTimes median_stages(const std::vector<rayfold::StageTimes>& frames);

// The folded and unfolded renders of one view side by side, with each one's
// median stage times.
void print_comparison(const rayfold::GBuffer& none, const rayfold::StageTimes& none_times,
                      const rayfold::GBuffer& folded, const rayfold::StageTimes& folded_times);

// An output name with one frame field (%d, %04d, ...): the name of frame f.
// Returns the name unchanged when it has no field; a second field or any
// other % is a usage error.
std::string frame_name(const std::string& option, const std::string& name, int frame, bool* has_field);

// rayfold::view_files(name, view_names), its InputError a usage error of
// `option`: the files a %s pattern names, checked.
std::vector<std::string> named_view_files(const std::string& option, const std::string& name,
                                          const std::vector<std::optional<std::string>>& view_names);

// The output of one view of a camera list or stereo pair (see render
// --help): `label` its index ("0", ...) or side ("left"), `view_name` the
// dataset's name for it.
std::string view_output(const std::string& option, const std::string& name, const std::string& label,
                        const std::string& view_name, bool stereo, size_t count);

}  // namespace rayfold::core::commands
