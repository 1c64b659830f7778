#include "scene/dataset_cameras.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <map>
#include <optional>
#include <sstream>

#include "util/errors.h"
#include "util/json_input.h"

namespace rayfold::core {
namespace {

using nlohmann::json;

// What a pinhole view is made of, at the top of a transforms.json or per frame.
const char* const kPinholeKeys[] = {"fl_x", "fl_y", "cx", "cy", "camera_angle_x", "camera_angle_y", "w", "h"};
const char* const kDistortionKeys[] = {"k1", "k2", "k3", "k4", "p1", "p2"};
// instant-ngp's and nerfstudio's keys that change no pinhole view: training
// settings, its own normalisation of the poses (rayfold renders the poses as
// written, in the scene's coordinates), paths of other images.
const char* const kIgnoredKeys[] = {"aabb_scale",    "scale",           "offset",      "sharpness",
                                    "colmap_im_id",  "rotation",        "applied_transform", "applied_scale",
                                    "ply_file_path", "depth_file_path", "mask_path",   "integer_depth_scale",
                                    "enable_depth_loading"};

template <size_t N>
bool one_of(const std::string& key, const char* const (&keys)[N]) {
  return std::find(std::begin(keys), std::end(keys), key) != std::end(keys);
}

double number(const json& j, const std::string& where, const std::string& path) { return json_number(j, where, path); }

// The keys of a top level or a frame: pinhole keys and "frames" or
// "transform_matrix" / "file_path" are read; the ignored ones are noted; a
// distortion coefficient must be 0; anything else is an error.
void check_keys(const json& j, const std::string& where, const std::string& path, bool frame,
                std::vector<std::string>* ignored) {
  for (const auto& item : j.items()) {
    const std::string& key = item.key();
    if (one_of(key, kPinholeKeys)) continue;
    if (frame ? (key == "transform_matrix" || key == "file_path") : key == "frames") continue;
    if (one_of(key, kDistortionKeys)) {
      if (number(item.value(), where + key, path) != 0.0)
        throw InputError(path, where + key + " is a lens distortion, which rayfold does not model: undistort the "
                                           "images first (a pinhole camera has k1 = k2 = p1 = p2 = 0)");
      continue;
    }
    if (key == "camera_model") {
      const std::string model = item.value().is_string() ? item.value().get<std::string>() : "";
      if (model != "OPENCV" && model != "PINHOLE" && model != "SIMPLE_PINHOLE")
        throw InputError(path, where + "camera_model " + item.value().dump() +
                                   " is not a pinhole model (OPENCV with zero distortion, PINHOLE, SIMPLE_PINHOLE)");
      continue;
    }
    if (key == "is_fisheye") {
      if (item.value() != json(false)) throw InputError(path, where + "is_fisheye: fisheye cameras are not modelled");
      continue;
    }
    if (one_of(key, kIgnoredKeys)) {
      if (ignored && std::find(ignored->begin(), ignored->end(), key) == ignored->end()) ignored->push_back(key);
      continue;
    }
    throw InputError(path, (where.empty() ? "" : where.substr(0, where.size() - 1) + ": ") + "unknown key \"" + key +
                               "\" (" +
                               (frame ? "a transforms.json frame has transform_matrix, file_path and"
                                      : "a transforms.json has frames and") +
                               " the intrinsics fl_x, fl_y, cx, cy, camera_angle_x, camera_angle_y, w, h)");
  }
}

}  // namespace

std::vector<DatasetView> read_nerf_cameras(const std::string& path, int width, int height,
                                           std::vector<std::string>* ignored, SkippedViews* skipped) {
  return read_nerf_cameras(read_json_object(path, "transforms file"), path, width, height, ignored, skipped);
}

std::string skip_reason(const InputError& e) { return e.what(); }  // the file is in it: it was said twice

std::string last_skip_reason(const SkippedViews& skipped, const std::string& path) {
  const std::string& reason = skipped.back().second;
  const std::string prefix = path + ": ";
  return reason.rfind(prefix, 0) == 0 ? reason.substr(prefix.size()) : reason;
}

std::vector<DatasetView> read_nerf_cameras(const json& top, const std::string& path, int width, int height,
                                           std::vector<std::string>* ignored, SkippedViews* skipped) {
  check_keys(top, "", path, false, ignored);
  if (!top.contains("frames") || !top["frames"].is_array() || top["frames"].empty())
    throw InputError(path, "\"frames\" must be a non-empty array");
  std::vector<DatasetView> views;
  for (size_t i = 0; i < top["frames"].size(); ++i) try {
    const json& fr = top["frames"][i];
    const std::string where = "frames[" + std::to_string(i) + "]";
    if (!fr.is_object()) throw InputError(path, where + " must be an object");
    check_keys(fr, where + ".", path, true, ignored);
    // A frame's own value, else the file's.
    auto get = [&](const char* key) -> std::optional<double> {
      if (fr.contains(key)) return number(fr[key], where + "." + key, path);
      if (top.contains(key)) return number(top[key], key, path);
      return std::nullopt;
    };
    auto pixels = [&](const char* key, int fallback) {
      const std::optional<double> v = get(key);
      if (!v) {
        if (fallback > 0) return fallback;
        throw InputError(path, where + " has no \"w\" and \"h\" (image size in pixels): add them to the file, or give "
                                       "the size (--size, or width= and height=)");
      }
      if (*v != std::floor(*v) || *v < 1 || *v > RF_MAX_IMAGE_SIDE)
        throw InputError(path, where + ": " + key + " must be a whole number of pixels from 1 to " +
                                   std::to_string(RF_MAX_IMAGE_SIDE));
      return static_cast<int>(*v);
    };
    const int w = pixels("w", width), h = pixels("h", height);
    std::optional<double> fx = get("fl_x"), fy = get("fl_y");
    if (!fx)
      if (const std::optional<double> a = get("camera_angle_x")) fx = 0.5 * w / std::tan(0.5 * *a);
    if (!fy)
      if (const std::optional<double> a = get("camera_angle_y")) fy = 0.5 * h / std::tan(0.5 * *a);
    if (!fx && !fy)
      throw InputError(path, where + " has no focal length: fl_x / fl_y (pixels) or camera_angle_x (radians)");
    if (!fx) fx = fy;
    if (!fy) fy = fx;
    const Intrinsics k{*fx, *fy, get("cx").value_or(0.5 * w), get("cy").value_or(0.5 * h)};
    if (!fr.contains("transform_matrix")) throw InputError(path, where + " has no \"transform_matrix\"");
    const json& m = fr["transform_matrix"];
    if (!m.is_array() || m.size() != 4) throw InputError(path, where + ".transform_matrix must be 4 rows of 4 numbers");
    Xform x;
    for (int r = 0; r < 4; ++r) {
      if (!m[r].is_array() || m[r].size() != 4)
        throw InputError(path, where + ".transform_matrix must be 4 rows of 4 numbers");
      for (int c = 0; c < 4; ++c) x[c][r] = number(m[r][c], where + ".transform_matrix", path);
    }
    std::string name = std::to_string(i);
    if (fr.contains("file_path")) {
      if (!fr["file_path"].is_string()) throw InputError(path, where + ".file_path must be a string");
      name = fr["file_path"].get<std::string>();
    }
    try {
      views.push_back({make_camera(x, k, w, h), name});
    } catch (const InputError& e) {
      if (!e.file().empty()) throw;
      throw InputError(path, where + ": " + e.what());
    }
  } catch (const InputError& e) {
    if (!skipped) throw;
    skipped->push_back({i, skip_reason(e)});
  }
  if (views.empty() && skipped)
    throw InputError(path, "has no frame that can be rendered; the last: " + last_skip_reason(*skipped, path));
  return views;
}

std::vector<DatasetView> read_colmap_cameras(const std::string& dir, SkippedViews* skipped) {
  struct Model {
    Intrinsics k;
    int width = 0, height = 0;
  };
  const std::string cameras_path = dir + "/cameras.txt", images_path = dir + "/images.txt";
  std::ifstream cf(cameras_path);
  if (!cf) throw InputError(cameras_path, "cannot open it (a COLMAP text model: cameras.txt and images.txt)");
  std::map<long, Model> models;
  std::string line;
  for (int n = 1; std::getline(cf, line); ++n) {
    if (line.empty() || line[0] == '#') continue;
    const std::string at = "line " + std::to_string(n);
    std::istringstream s(line);
    long id = 0;
    std::string model;
    Model m;
    if (!(s >> id >> model >> m.width >> m.height))
      throw InputError(cameras_path, at + ": expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]");
    std::vector<double> p{std::istream_iterator<double>(s), std::istream_iterator<double>()};
    if (!s.eof()) throw InputError(cameras_path, at + ": a parameter is not a number");
    if (model == "PINHOLE" && p.size() == 4) {
      m.k = {p[0], p[1], p[2], p[3]};
    } else if (model == "SIMPLE_PINHOLE" && p.size() == 3) {
      m.k = {p[0], p[0], p[1], p[2]};
    } else if (model == "PINHOLE" || model == "SIMPLE_PINHOLE") {
      throw InputError(cameras_path, at + ": " + model + " takes " + (model == "PINHOLE" ? "4" : "3") +
                                         " parameters, not " + std::to_string(p.size()));
    } else {
      throw InputError(cameras_path, at + ": camera " + std::to_string(id) + " is " + model +
                                         ", a model with lens distortion, which rayfold does not model; undistort "
                                         "the images (colmap image_undistorter writes PINHOLE cameras)");
    }
    if (!models.emplace(id, m).second)
      throw InputError(cameras_path, at + ": camera " + std::to_string(id) + " is given twice");
  }
  std::ifstream imf(images_path);
  if (!imf) throw InputError(images_path, "cannot open it (a COLMAP text model: cameras.txt and images.txt)");
  std::vector<DatasetView> views;
  // After the comments, two lines per image: its pose, then its 2D points
  // (which may be empty).
  bool points_next = false;
  size_t image_index = 0;
  for (int n = 1; std::getline(imf, line); ++n) {
    if (points_next) {
      points_next = false;
      continue;
    }
    if (line.empty() || line[0] == '#') continue;
    const std::string at = "line " + std::to_string(n);
    std::istringstream s(line);
    long image_id = 0, camera_id = 0;
    double q[4], t[3];
    if (!(s >> image_id >> q[0] >> q[1] >> q[2] >> q[3] >> t[0] >> t[1] >> t[2] >> camera_id))
      throw InputError(images_path, at + ": expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME");
    std::string name;
    std::getline(s >> std::ws, name);
    points_next = true;
    const size_t index = image_index++;
    try {
    if (name.empty()) throw InputError(images_path, at + ": image " + std::to_string(image_id) + " has no NAME");
    const auto model = models.find(camera_id);
    if (model == models.end())
      throw InputError(images_path, at + ": image " + std::to_string(image_id) + " names camera " +
                                        std::to_string(camera_id) + ", which cameras.txt does not have");
    const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (!(norm > 0.0) || !std::isfinite(norm))
      throw InputError(images_path, at + ": the rotation quaternion of image " + std::to_string(image_id) +
                                        " is zero or not finite");
    const double w = q[0] / norm, x = q[1] / norm, y = q[2] / norm, z = q[3] / norm;
    // camera_from_world's rotation R (rows), from the unit quaternion.
    const double R[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
                            {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
                            {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}};
    // world_from_camera = [R^T | -R^T t], then OpenCV's camera axes to
    // rayfold's (+y up, looking down -z): columns 1 and 2 negated.
    Xform world_from_camera(1.0);
    for (int c = 0; c < 3; ++c) {
      for (int r = 0; r < 3; ++r) world_from_camera[c][r] = R[c][r] * (c == 0 ? 1.0 : -1.0);
      world_from_camera[3][c] = -(R[0][c] * t[0] + R[1][c] * t[1] + R[2][c] * t[2]);
    }
    try {
      views.push_back({make_camera(world_from_camera, model->second.k, model->second.width, model->second.height),
                       name});
    } catch (const InputError& e) {
      if (!e.file().empty()) throw;
      throw InputError(images_path, at + ": image " + std::to_string(image_id) + ": " + e.what());
    }
    } catch (const InputError& e) {
      if (!skipped) throw;
      skipped->push_back({index, skip_reason(e)});
    }
  }
  if (views.empty())
    throw InputError(images_path, skipped && !skipped->empty() ? "has no image that can be rendered; the last: " +
                                                                     last_skip_reason(*skipped, images_path)
                                                               : "has no image");
  return views;
}

std::string view_file_stem(const std::string& name) {
  std::string base = name;
  while (!base.empty() && base.back() == '/') base.pop_back();
  const size_t slash = base.find_last_of('/');
  if (slash != std::string::npos) base = base.substr(slash + 1);
  if (base == "." || base == "..") return "";
  const size_t dot = base.rfind('.');
  if (dot != std::string::npos && dot > 0) base.resize(dot);
  return base;
}

}  // namespace rayfold::core
