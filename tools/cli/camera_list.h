// --cameras FILE.json and --stereo: the views one render command traces.
#pragma once

#include <string>
#include <vector>

#include "scene/camera.h"

namespace rayfold::core::cli {

struct View {
  Camera camera;
  std::string label;  // "0", "1", ... for a camera list; "left", "right" for a stereo pair
  std::string name;   // the dataset's name of the view (DatasetView::name); empty for a stereo pair
};

// --cameras FILE: a camera list (scene/camera_list.h), or a NeRF / instant-ngp
// transforms.json (a JSON object with "frames"; scene/dataset_cameras.h).
// width and height: --size when given, else 0; only a transforms.json
// without "w" and "h" takes them, anything else refuses them. A line about
// the keys a transforms.json has that change no view goes to *note.
std::vector<View> read_cameras_file(const std::string& path, int width, int height, std::string* note);

// --colmap DIR: a COLMAP text model's images, in images.txt's order.
std::vector<View> read_colmap_dir(const std::string& dir);

// A parallel-axis stereo pair around `centre`: the eyes baseline / 2 to the
// left and right along the camera's right vector, looking the same way.
std::vector<View> stereo_pair(const CameraSpec& centre, double baseline, int width, int height);

}  // namespace rayfold::core::cli
