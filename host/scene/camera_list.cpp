#include "scene/camera_list.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <optional>

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "scene/dataset_cameras.h"
#include "util/errors.h"
#include "util/json_input.h"

namespace rayfold::core {
namespace {

using nlohmann::json;

double number(const json& j, const std::string& where, const std::string& path) { return json_number(j, where, path); }

glm::dvec3 vec3(const json& j, const std::string& where, const std::string& path) {
  if (!j.is_array() || j.size() != 3) throw InputError(path, where + " must be an array of 3 numbers");
  return glm::dvec3(number(j[0], where + "[0]", path), number(j[1], where + "[1]", path),
                    number(j[2], where + "[2]", path));
}

int side(const json& j, const char* key, const std::string& path) {
  if (!j.contains(key)) throw InputError(path, std::string("has no \"") + key + "\" (image size in pixels)");
  const double v = number(j[key], key, path);
  if (v != std::floor(v) || v < 1 || v > RF_MAX_IMAGE_SIDE)
    throw InputError(
        path, std::string(key) + " must be a whole number of pixels from 1 to " + std::to_string(RF_MAX_IMAGE_SIDE));
  return static_cast<int>(v);
}

// Pinhole intrinsics given in `j` (the list or one camera): fx, fy, cx, cy
// in pixels, or "K", the 3x3 matrix row-major (9 numbers or 3 rows of 3,
// no skew, last row 0 0 1). Pixel centres are at +0.5 as everywhere in
// rayfold (add 0.5 to an OpenCV calibration's cx, cy). None when `j` gives
// neither; InputError for half a set or both forms.
std::optional<Intrinsics> read_intrinsics(const json& j, const std::string& where, const std::string& path) {
  const bool any = j.contains("fx") || j.contains("fy") || j.contains("cx") || j.contains("cy");
  if (any && j.contains("K")) throw InputError(path, where + " gives both \"K\" and fx, fy, cx, cy: name one");
  const std::string at = where.empty() ? "" : where + ".";
  if (any) {
    for (const char* key : {"fx", "fy", "cx", "cy"})
      if (!j.contains(key))
        throw InputError(path, where + (where.empty() ? "" : ": ") + "fx, fy, cx and cy go together; \"" + key +
                                   "\" is missing (pixels, pixel centres at +0.5)");
    return Intrinsics{number(j["fx"], at + "fx", path), number(j["fy"], at + "fy", path),
                      number(j["cx"], at + "cx", path), number(j["cy"], at + "cy", path)};
  }
  if (!j.contains("K")) return std::nullopt;
  std::vector<double> k;
  const json& m = j["K"];
  const std::string what = at + "K";
  if (m.is_array() && m.size() == 3) {
    for (size_t r = 0; r < 3; ++r) {
      if (!m[r].is_array() || m[r].size() != 3) throw InputError(path, what + " must be 3 rows of 3 numbers");
      for (size_t c = 0; c < 3; ++c) k.push_back(number(m[r][c], what, path));
    }
  } else if (m.is_array() && m.size() == 9) {
    for (const json& v : m) k.push_back(number(v, what, path));
  } else {
    throw InputError(path, what + " must be a 3x3 matrix: 9 numbers row-major or 3 rows of 3");
  }
  if (k[1] != 0.0 || k[3] != 0.0 || k[6] != 0.0 || k[7] != 0.0 || k[8] != 1.0)
    throw InputError(path, what + " must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] (no skew)");
  return Intrinsics{k[0], k[4], k[2], k[5]};
}

}  // namespace

std::vector<Camera> read_camera_list_json(const json& j, const std::string& path, SkippedViews* skipped) {
  // Nothing the list says is dropped: a misspelt "convention" or "vfov"
  // rendered OpenGL poses at 60 degrees without a word. A benchmark's JSON
  // report (rayfold-peers --json: its rows and machine beside the views it
  // drew, docs/benchmarks.md) is a list too, its other members the report's.
  const bool report = j.contains("rows") && j.contains("machine");
  static const char* const kKeys[] = {"width", "height", "vfov", "convention", "cameras", "fx", "fy", "cx", "cy", "K"};
  if (!report)
    for (const auto& item : j.items())
      if (std::find(std::begin(kKeys), std::end(kKeys), item.key()) == std::end(kKeys))
        throw InputError(path, "unknown key \"" + item.key() +
                                   "\" (a camera list has width, height, cameras, convention, and vfov or fx, fy, "
                                   "cx, cy or K)");
  const int width = side(j, "width", path), height = side(j, "height", path);
  const double vfov = j.contains("vfov") ? number(j["vfov"], "vfov", path) : 60.0;
  const std::optional<Intrinsics> list_k = read_intrinsics(j, "", path);
  if (list_k && j.contains("vfov")) throw InputError(path, "gives both vfov and intrinsics: name one");
  const std::string convention = j.value("convention", std::string("opengl"));
  if (convention != "opengl" && convention != "opencv")
    throw InputError(path, "convention must be \"opengl\" (-z forward) or \"opencv\" (+z forward, +y down)");
  if (!j.contains("cameras") || !j["cameras"].is_array() || j["cameras"].empty())
    throw InputError(path, "\"cameras\" must be a non-empty array");
  std::vector<Camera> views;
  for (size_t i = 0; i < j["cameras"].size(); ++i) try {
    const json& c = j["cameras"][i];
    const std::string where = "cameras[" + std::to_string(i) + "]";
    if (!c.is_object()) throw InputError(path, where + " must be an object");
    // Nothing a camera says is dropped: intrinsics (fx, fy, cx, cy, K) would
    // otherwise render at the list's vfov without a word.
    for (const auto& item : c.items()) {
      static const char* const kKeys[] = {"eye", "look_at", "up", "vfov", "camera_to_world",
                                          "fx",  "fy",      "cx", "cy",   "K"};
      if (std::find(std::begin(kKeys), std::end(kKeys), item.key()) == std::end(kKeys))
        throw InputError(path, where + ": unknown key \"" + item.key() +
                                   "\" (a camera has eye, look_at, up, camera_to_world, and vfov or fx, fy, cx, cy "
                                   "or K)");
    }
    // One pose: camera_to_world beside eye, look_at or up won over them silently.
    for (const char* key : {"eye", "look_at", "up"})
      if (c.contains("camera_to_world") && c.contains(key))
        throw InputError(path, where + " gives both camera_to_world and \"" + key +
                                   "\": name the pose one way (eye, look_at and up, or camera_to_world)");
    const std::optional<Intrinsics> own_k = read_intrinsics(c, where, path);
    if (own_k && c.contains("vfov")) throw InputError(path, where + " gives both vfov and intrinsics: name one");
    // A camera's own field of view or intrinsics, else the list's.
    const std::optional<Intrinsics> k = own_k ? own_k : c.contains("vfov") ? std::nullopt : list_k;
    const double fov = c.contains("vfov") ? number(c["vfov"], where + ".vfov", path) : vfov;
    try {
      if (c.contains("camera_to_world")) {
        const json& m = c["camera_to_world"];
        if (!m.is_array() || m.size() != 16)
          throw InputError(path, where + ".camera_to_world must be an array of 16 numbers (row-major)");
        Xform x;
        for (int r = 0; r < 4; ++r)
          for (int k = 0; k < 4; ++k)
            x[k][r] = number(m[4 * r + k], where + ".camera_to_world[" + std::to_string(4 * r + k) + "]", path);
        if (convention == "opencv") {
          x[1] = -x[1];
          x[2] = -x[2];
        }
        if (!k && !(fov > 0.0 && fov < 180.0)) throw InputError(path, where + ": vfov must be in (0, 180) degrees");
        const double f = 0.5 * height / std::tan(fov * M_PI / 360.0);
        views.push_back(make_camera(x, k ? *k : Intrinsics{f, f, 0.5 * width, 0.5 * height}, width, height));
      } else {
        CameraSpec spec;
        if (!c.contains("eye") || !c.contains("look_at"))
          throw InputError(path, where + " needs \"eye\" and \"look_at\", or \"camera_to_world\"");
        spec.eye = vec3(c["eye"], where + ".eye", path);
        spec.look_at = vec3(c["look_at"], where + ".look_at", path);
        if (c.contains("up")) spec.up = vec3(c["up"], where + ".up", path);
        spec.vfov_degrees = fov;
        Camera camera = make_camera(spec, width, height);
        if (k) camera = make_camera(camera.world_from_camera, *k, width, height);  // the pose, these intrinsics
        views.push_back(camera);
      }
    } catch (const InputError& e) {
      if (!e.file().empty()) throw;
      throw InputError(path, where + ": " + e.what());  // make_camera's reason, with the camera named
    }
  } catch (const InputError& e) {
    if (!skipped) throw;
    skipped->push_back({i, skip_reason(e)});
  }
  if (views.empty() && skipped)
    throw InputError(path, "has no camera that can be rendered; the last: " + last_skip_reason(*skipped, path));
  return views;
}

std::vector<Camera> read_camera_list(const std::string& path) {
  return read_camera_list_json(read_json_object(path, "camera list"), path);
}

std::vector<DatasetView> read_cameras_any(const std::string& path, int width, int height,
                                          std::vector<std::string>* ignored, const std::string& size_given_by,
                                          SkippedViews* skipped) {
  const json j = read_json_object(path, "camera list");
  const bool nerf = j.contains("frames") && !j.contains("cameras");
  const bool size_given = width > 0 && height > 0;
  if (nerf) {
    if (size_given && j.contains("w") && j.contains("h"))
      throw InputError(path, "gives the image size (w, h); " + size_given_by + " does not combine with it");
    return read_nerf_cameras(j, path, width, height, ignored, skipped);
  }
  if (size_given) throw InputError(path, "gives the size of its views; " + size_given_by + " does not combine with it");
  std::vector<DatasetView> views;
  const SkippedViews before = skipped ? *skipped : SkippedViews{};
  std::vector<Camera> cameras = read_camera_list_json(j, path, skipped);
  // A list's views are named by their index in the file.
  size_t i = 0, next_skip = before.size();
  for (Camera& c : cameras) {
    while (skipped && next_skip < skipped->size() && (*skipped)[next_skip].first == i) ++i, ++next_skip;
    views.push_back({c, std::to_string(i++)});
  }
  return views;
}

}  // namespace rayfold::core
