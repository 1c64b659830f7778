#include "cli/camera_list.h"

#include "scene/camera_list.h"
#include "scene/dataset_cameras.h"
#include "util/errors.h"
#include "util/json_input.h"

namespace rayfold::core::cli {

std::vector<View> read_cameras_file(const std::string& path, int width, int height, std::string* note) {
  std::vector<std::string> ignored;
  std::vector<View> views;
  size_t i = 0;
  for (DatasetView& v : read_cameras_any(path, width, height, &ignored, "--size"))
    views.push_back({v.camera, std::to_string(i++), v.name});
  if (note && !ignored.empty()) {
    std::string keys;
    for (const std::string& k : ignored) keys += (keys.empty() ? "" : ", ") + k;
    *note = path + ": ignored " + keys + " (training settings and instant-ngp's own pose normalisation: the poses " +
            "are rendered as written, in the scene's coordinates)";
  }
  return views;
}

std::vector<View> read_colmap_dir(const std::string& dir) {
  std::vector<View> views;
  size_t i = 0;
  for (DatasetView& v : read_colmap_cameras(dir)) views.push_back({v.camera, std::to_string(i++), v.name});
  return views;
}

std::vector<View> stereo_pair(const CameraSpec& centre, double baseline, int width, int height) {
  const std::array<CameraSpec, 2> eyes = stereo_specs(centre, baseline);
  return {{make_camera(eyes[0], width, height), "left"}, {make_camera(eyes[1], width, height), "right"}};
}

}  // namespace rayfold::core::cli
