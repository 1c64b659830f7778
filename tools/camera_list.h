// --cameras FILE.json and --stereo: the views one render command traces.
#pragma once

#include <string>
#include <vector>

#include "scene/camera.h"

namespace rayfold::core::cli {

struct View {
  Camera camera;
  std::string label;  // "0", "1", ... for a camera list; "left", "right" for a stereo pair
};

// Reads {"width": W, "height": H, "vfov": DEG, "convention": "opengl"|"opencv",
//        "cameras": [{"eye": [x,y,z], "look_at": [x,y,z], "up": [x,y,z]}
//                    or {"camera_to_world": [16 numbers, row-major]}, each
//                    with an optional "vfov"]}.
// vfov defaults to 60, up to +Y, convention (of camera_to_world) to opengl.
// Throws InputError(path, ...) naming the member that is wrong, also for a
// key a camera does not have (fx, fy, cx, cy are not read yet).
std::vector<View> read_camera_list(const std::string& path);

// A parallel-axis stereo pair around `centre`: the eyes baseline / 2 to the
// left and right along the camera's right vector, looking the same way.
std::vector<View> stereo_pair(const CameraSpec& centre, double baseline, int width, int height);

}  // namespace rayfold::core::cli
