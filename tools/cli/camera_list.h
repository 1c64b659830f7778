// --cameras FILE.json, --colmap DIR and --stereo: the views one render
// command traces, read by the public API's readers.
#pragma once

#include <string>
#include <vector>

#include "rayfold/camera.h"

namespace rayfold::core::cli {

struct View {
  rayfold::Camera camera;
  std::string label;  // "0", "1", ... for a camera list; "left", "right" for a stereo pair
  std::string name;   // the dataset's name of the view (a file_path, an image name); empty for a stereo pair
};

// --cameras FILE: a camera list or a NeRF / instant-ngp transforms.json
// (rayfold::Camera::from_file). width and height: --size when given, else
// 0. A line about the keys a transforms.json has that change no view goes
// to *note.
std::vector<View> read_cameras_file(const std::string& path, int width, int height, std::string* note);

// --colmap DIR: a COLMAP text model's images, in images.txt's order.
std::vector<View> read_colmap_dir(const std::string& dir);

// --stereo B: a parallel-axis stereo pair around `centre`, the eyes B / 2 to
// the left and right along the camera's right vector, looking the same way.
std::vector<View> stereo_pair(const rayfold::View& centre, double baseline, int width, int height);

}  // namespace rayfold::core::cli
