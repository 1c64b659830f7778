// rayfold's camera list: a JSON file of views of one size (the CLI's
// --cameras FILE.json, Camera.from_file in Python).
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "scene/camera.h"
#include "scene/dataset_cameras.h"

namespace rayfold::core {

// Reads {"width": W, "height": H, "vfov": DEG, "convention": "opengl"|"opencv",
//        "cameras": [{"eye": [x,y,z], "look_at": [x,y,z], "up": [x,y,z]}
//                    or {"camera_to_world": [16 numbers, row-major]}, each
//                    with an optional "vfov", or "fx", "fy", "cx", "cy" or
//                    "K" in pixels (pixel centres at +0.5)]}; the list too
// may give intrinsics instead of vfov. vfov defaults to 60, up to +Y,
// convention (of camera_to_world) to opengl. Throws InputError(path, ...)
// naming the member that is wrong, also for a key a camera does not have.
std::vector<Camera> read_camera_list(const std::string& path);
// skipped: as the dataset readers' (scene/dataset_cameras.h).
std::vector<Camera> read_camera_list_json(const nlohmann::json& j, const std::string& path,
                                          SkippedViews* skipped = nullptr);

// A camera list or a NeRF / instant-ngp transforms.json (an object with
// "frames" and no "cameras"), told apart by content; a list's views are
// named "0", "1", ..., a transforms.json's by file_path. width and height
// (0: not given) only for a transforms.json without "w" and "h", as
// read_nerf_cameras, which also fills *ignored; size_given_by names where a
// size came from in the error that refuses it ("--size").
std::vector<DatasetView> read_cameras_any(const std::string& path, int width, int height,
                                          std::vector<std::string>* ignored, const std::string& size_given_by,
                                          SkippedViews* skipped = nullptr);

}  // namespace rayfold::core
