#include "cli/camera_list.h"

namespace rayfold::core::cli {
namespace {

std::vector<View> numbered(std::vector<std::pair<std::string, rayfold::Camera>> named) {
  std::vector<View> views;
  views.reserve(named.size());
  for (auto& [name, camera] : named)
    views.push_back({std::move(camera), std::to_string(views.size()), std::move(name)});
  return views;
}

}  // namespace

std::vector<View> read_cameras_file(const std::string& path, int width, int height, std::string* note) {
  std::vector<std::string> ignored;
  std::vector<View> views = numbered(rayfold::Camera::from_file(path, width, height, &ignored, nullptr, "--size"));
  if (note && !ignored.empty()) {
    std::string keys;
    for (const std::string& k : ignored) keys += (keys.empty() ? "" : ", ") + k;
    *note = path + ": ignored " + keys + " (training settings and instant-ngp's own pose normalisation: the poses " +
            "are rendered as written, in the scene's coordinates)";
  }
  return views;
}

std::vector<View> read_colmap_dir(const std::string& dir) { return numbered(rayfold::Camera::from_colmap(dir)); }

std::vector<View> stereo_pair(const rayfold::View& centre, double baseline, int width, int height) {
  const auto eyes =
      rayfold::Camera::stereo_pair(centre.eye, centre.target, centre.up, centre.vfov_degrees, width, height, baseline);
  return {{eyes[0], "left", ""}, {eyes[1], "right", ""}};
}

}  // namespace rayfold::core::cli
