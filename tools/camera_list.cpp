#include "camera_list.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <fstream>

#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include "util/errors.h"

namespace rayfold::core::cli {
namespace {

using nlohmann::json;

double number(const json& j, const std::string& where, const std::string& path) {
  if (!j.is_number()) throw InputError(path, where + " must be a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) throw InputError(path, where + " must be finite");
  return v;
}

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

}  // namespace

std::vector<View> read_camera_list(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw InputError(path, "cannot open the camera list");
  const json j = json::parse(f, nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw InputError(path, "is not a JSON object");
  const int width = side(j, "width", path), height = side(j, "height", path);
  const double vfov = j.contains("vfov") ? number(j["vfov"], "vfov", path) : 60.0;
  const std::string convention = j.value("convention", std::string("opengl"));
  if (convention != "opengl" && convention != "opencv")
    throw InputError(path, "convention must be \"opengl\" (-z forward) or \"opencv\" (+z forward, +y down)");
  if (!j.contains("cameras") || !j["cameras"].is_array() || j["cameras"].empty())
    throw InputError(path, "\"cameras\" must be a non-empty array");
  std::vector<View> views;
  for (size_t i = 0; i < j["cameras"].size(); ++i) {
    const json& c = j["cameras"][i];
    const std::string where = "cameras[" + std::to_string(i) + "]";
    if (!c.is_object()) throw InputError(path, where + " must be an object");
    // Nothing a camera says is dropped: intrinsics (fx, fy, cx, cy, K) would
    // otherwise render at the list's vfov without a word.
    for (const auto& item : c.items()) {
      static const char* const kKeys[] = {"eye", "look_at", "up", "vfov", "camera_to_world"};
      if (std::find(std::begin(kKeys), std::end(kKeys), item.key()) == std::end(kKeys))
        throw InputError(path, where + ": unknown key \"" + item.key() +
                                   "\" (a camera has eye, look_at, up, vfov or camera_to_world; intrinsics such as "
                                   "fx, fy, cx, cy are not read)");
    }
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
        if (!(fov > 0.0 && fov < 180.0)) throw InputError(path, where + ": vfov must be in (0, 180) degrees");
        const double f = 0.5 * height / std::tan(fov * M_PI / 360.0);
        views.push_back(
            {make_camera(x, Intrinsics{f, f, 0.5 * width, 0.5 * height}, width, height), std::to_string(i)});
      } else {
        CameraSpec spec;
        if (!c.contains("eye") || !c.contains("look_at"))
          throw InputError(path, where + " needs \"eye\" and \"look_at\", or \"camera_to_world\"");
        spec.eye = vec3(c["eye"], where + ".eye", path);
        spec.look_at = vec3(c["look_at"], where + ".look_at", path);
        if (c.contains("up")) spec.up = vec3(c["up"], where + ".up", path);
        spec.vfov_degrees = fov;
        views.push_back({make_camera(spec, width, height), std::to_string(i)});
      }
    } catch (const InputError& e) {
      if (!e.file().empty()) throw;
      throw InputError(path, where + ": " + e.what());  // make_camera's reason, with the camera named
    }
  }
  return views;
}

std::vector<View> stereo_pair(const CameraSpec& centre, double baseline, int width, int height) {
  const std::array<CameraSpec, 2> eyes = stereo_specs(centre, baseline);
  return {{make_camera(eyes[0], width, height), "left"}, {make_camera(eyes[1], width, height), "right"}};
}

}  // namespace rayfold::core::cli
