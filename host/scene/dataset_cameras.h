// Cameras of the two dataset formats G-buffer users have: NeRF / instant-ngp
// transforms.json and COLMAP text models. Pinhole only: a distortion model
// or coefficient is refused by name (undistort the images first), never
// dropped.
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "scene/camera.h"
#include "util/errors.h"

namespace rayfold::core {

struct DatasetView {
  Camera camera;
  std::string name;  // the frame's file_path, the COLMAP image's name
};

// Views a lenient reader left out: (the view's index in the file, why).
// Given to a reader, a view whose own entry is bad is listed here instead
// of throwing (the file's structure still throws): a batch renders the rest
// and reports these.
using SkippedViews = std::vector<std::pair<size_t, std::string>>;

// A NeRF transforms.json: per frame a 4x4 camera-to-world "transform_matrix"
// (OpenGL axes: +y up, looking down -z), intrinsics from "fl_x"/"fl_y" (or
// one of them, square pixels), "cx"/"cy" (default: the image centre) or
// "camera_angle_x" (and "camera_angle_y"), the size from "w"/"h"; every one
// of these at the top or per frame (a frame's own wins). Principal points
// are in pixels with centres at +0.5, as COLMAP writes them. Files without
// "w" and "h" (the original synthetic scenes) take width x height when those
// are positive. Keys that do not change a pinhole view (aabb_scale, scale,
// offset and the like, instant-ngp's training settings) are ignored and
// listed in *ignored; any other key, or a nonzero distortion coefficient, is
// an InputError naming it and the frame.
std::vector<DatasetView> read_nerf_cameras(const std::string& path, int width = 0, int height = 0,
                                           std::vector<std::string>* ignored = nullptr,
                                           SkippedViews* skipped = nullptr);
// The same from the file's parsed top-level object (path names it in errors).
std::vector<DatasetView> read_nerf_cameras(const nlohmann::json& top, const std::string& path, int width, int height,
                                           std::vector<std::string>* ignored, SkippedViews* skipped = nullptr);

// A COLMAP text model: dir/cameras.txt (PINHOLE, SIMPLE_PINHOLE; other
// models are refused by name) and dir/images.txt (world-to-camera rotation
// quaternion and translation, OpenCV axes), in images.txt's order. COLMAP's
// pixel centres are at +0.5 as rayfold's.
// A view's index is its image's position in images.txt.
std::vector<DatasetView> read_colmap_cameras(const std::string& dir, SkippedViews* skipped = nullptr);

// What a view's name gives an output file's name (`%s` in -o): its last
// path component without its extension ("./train/r_0" -> "r_0", "a.jpg" ->
// "a"), so that every view of a dataset lands in the one output folder.
// Empty where nothing is left ("", "./", "..").
std::string view_file_stem(const std::string& name);

// "file: message" of an InputError, for SkippedViews.
std::string skip_reason(const InputError& e);
// The last skipped view's reason without its leading "path: ", for an
// error about `path` that quotes it.
std::string last_skip_reason(const SkippedViews& skipped, const std::string& path);

}  // namespace rayfold::core
