#include "rayfold/camera.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>

#include <glm/geometric.hpp>

#include "api/convert.h"
#include "rayfold/errors.h"
#include "scene/camera.h"
#include "scene/camera_list.h"
#include "scene/dataset_cameras.h"

namespace rayfold {
namespace {

// OpenCV's camera axes are OpenGL's with y and z negated.
core::Xform flip_yz() {
  core::Xform f(1.0);
  f[1][1] = -1.0;
  f[2][2] = -1.0;
  return f;
}

core::CameraSpec pose(const Vec3& eye, const Vec3& target, const Vec3& up) {
  core::CameraSpec spec;
  spec.eye = glm::dvec3(eye[0], eye[1], eye[2]);
  spec.look_at = glm::dvec3(target[0], target[1], target[2]);
  spec.up = glm::dvec3(up[0], up[1], up[2]);
  return spec;
}

}  // namespace

Camera Camera::look_at(const Vec3& eye, const Vec3& target, const Vec3& up, double vfov_degrees, int width,
                       int height) {
  core::CameraSpec spec = pose(eye, target, up);
  spec.vfov_degrees = vfov_degrees;
  return Camera(std::make_shared<core::Camera>(core::make_camera(spec, width, height)));
}

Camera Camera::from_view(const View& view, int width, int height, double shift_x, double shift_y) {
  core::CameraSpec spec = pose(view.eye, view.target, view.up);
  if (!view.orthographic) spec.vfov_degrees = view.vfov_degrees;  // as orthographic() leaves it
  spec.orthographic = view.orthographic;
  spec.ymag = view.half_height;
  return Camera(std::make_shared<core::Camera>(core::make_camera(spec, width, height, shift_x, shift_y)));
}

std::array<Camera, 2> Camera::stereo_pair(const Vec3& eye, const Vec3& target, const Vec3& up, double vfov_degrees,
                                          int width, int height, double baseline) {
  if (!(baseline > 0.0) || !std::isfinite(baseline))
    throw InputError("", "a stereo baseline must be positive and finite, not " + std::to_string(baseline));
  core::CameraSpec spec = pose(eye, target, up);
  spec.vfov_degrees = vfov_degrees;
  core::make_camera(spec, width, height);  // the centre view's checks
  const std::array<core::CameraSpec, 2> eyes = core::stereo_specs(spec, baseline);
  return {Camera(std::make_shared<core::Camera>(core::make_camera(eyes[0], width, height))),
          Camera(std::make_shared<core::Camera>(core::make_camera(eyes[1], width, height)))};
}

Camera Camera::orthographic(const Vec3& eye, const Vec3& target, const Vec3& up, double half_height, int width,
                            int height) {
  core::CameraSpec spec = pose(eye, target, up);
  spec.orthographic = true;
  spec.ymag = half_height;
  return Camera(std::make_shared<core::Camera>(core::make_camera(spec, width, height)));
}

Camera Camera::from_matrix(const Matrix4& camera_to_world, const Intrinsics& k, int width, int height,
                           CameraConvention convention) {
  detail::check_affine(camera_to_world, "camera-to-world matrix");
  core::Xform world_from_camera = detail::to_xform(camera_to_world);
  if (convention == CameraConvention::opencv) world_from_camera = world_from_camera * flip_yz();
  core::Intrinsics ki{k.fx, k.fy, k.cx, k.cy};
  return Camera(std::make_shared<core::Camera>(core::make_camera(world_from_camera, ki, width, height)));
}

std::vector<std::pair<std::string, Camera>> Camera::from_nerf(const std::string& path, int width, int height,
                                                              std::vector<std::string>* ignored) {
  std::vector<std::pair<std::string, Camera>> out;
  for (core::DatasetView& v : core::read_nerf_cameras(path, width, height, ignored))
    out.emplace_back(v.name, Camera(std::make_shared<core::Camera>(v.camera)));
  return out;
}

std::vector<std::pair<std::string, Camera>> Camera::from_colmap(const std::string& dir,
                                                                std::vector<std::pair<size_t, std::string>>* skipped) {
  std::vector<std::pair<std::string, Camera>> out;
  for (core::DatasetView& v : core::read_colmap_cameras(dir, skipped))
    out.emplace_back(v.name, Camera(std::make_shared<core::Camera>(v.camera)));
  return out;
}

std::vector<std::pair<std::string, Camera>> Camera::from_file(const std::string& path, int width, int height,
                                                              std::vector<std::string>* ignored,
                                                              std::vector<std::pair<size_t, std::string>>* skipped,
                                                              const std::string& size_words) {
  std::vector<std::pair<std::string, Camera>> out;
  for (core::DatasetView& v : core::read_cameras_any(path, width, height, ignored, size_words, skipped))
    out.emplace_back(v.name, Camera(std::make_shared<core::Camera>(v.camera)));
  return out;
}

namespace {

// "rfcam", a format version byte, then the fields in this order, native
// byte order: world_from_camera and camera_from_world (16 doubles each,
// column-major), width and height (int32), vfov_degrees, the device's
// rf_camera (its documented bytes), scale_x, scale_y, frac_x, frac_y.
constexpr char kCameraMagic[] = "rfcam\x01";
constexpr size_t kCameraBytes = sizeof(kCameraMagic) - 1 + 32 * sizeof(double) + 2 * sizeof(int32_t) +
                                sizeof(double) + sizeof(rf_camera) + 4 * sizeof(double);

}  // namespace

std::string Camera::to_bytes() const {
  const core::Camera& c = *impl_;
  std::string out(kCameraMagic, sizeof(kCameraMagic) - 1);
  auto put = [&](const void* p, size_t n) { out.append(static_cast<const char*>(p), n); };
  put(&c.world_from_camera[0][0], 16 * sizeof(double));
  put(&c.camera_from_world[0][0], 16 * sizeof(double));
  const int32_t size[2] = {c.width, c.height};
  put(size, sizeof(size));
  put(&c.vfov_degrees, sizeof(double));
  put(&c.params, sizeof(rf_camera));
  const double exact[4] = {c.scale_x, c.scale_y, c.frac_x, c.frac_y};
  put(exact, sizeof(exact));
  return out;
}

Camera Camera::from_bytes(const std::string& bytes) {
  const size_t magic = sizeof(kCameraMagic) - 1;
  if (bytes.size() != kCameraBytes || bytes.compare(0, magic, kCameraMagic, magic) != 0)
    throw InputError("", "Camera.from_bytes: " + std::to_string(bytes.size()) +
                             " bytes that are not a camera of this rayfold version (" + std::to_string(kCameraBytes) +
                             " bytes starting \"rfcam\" and format 1)");
  auto c = std::make_shared<core::Camera>();
  size_t at = magic;
  auto get = [&](void* p, size_t n) {
    std::memcpy(p, bytes.data() + at, n);
    at += n;
  };
  get(&c->world_from_camera[0][0], 16 * sizeof(double));
  get(&c->camera_from_world[0][0], 16 * sizeof(double));
  int32_t size[2];
  get(size, sizeof(size));
  c->width = size[0];
  c->height = size[1];
  get(&c->vfov_degrees, sizeof(double));
  get(&c->params, sizeof(rf_camera));
  double exact[4];
  get(exact, sizeof(exact));
  c->scale_x = exact[0];
  c->scale_y = exact[1];
  c->frac_x = exact[2];
  c->frac_y = exact[3];
  return Camera(std::move(c));
}

int Camera::width() const { return impl_->width; }
int Camera::height() const { return impl_->height; }

Matrix4 Camera::camera_to_world(CameraConvention convention) const {
  const core::Xform& m = impl_->world_from_camera;
  return detail::to_matrix(convention == CameraConvention::opencv ? m * flip_yz() : m);
}

Matrix4 Camera::world_to_camera(CameraConvention convention) const {
  const core::Xform& m = impl_->camera_from_world;
  return detail::to_matrix(convention == CameraConvention::opencv ? flip_yz() * m : m);
}

Intrinsics Camera::intrinsics() const {
  const core::Intrinsics k = core::intrinsics(*impl_);
  return {k.fx, k.fy, k.cx, k.cy};
}

Vec3 Camera::eye() const {
  const glm::dvec3 e(impl_->world_from_camera[3]);
  return {e.x, e.y, e.z};
}

double Camera::vfov_degrees() const { return impl_->vfov_degrees; }

Vec3 Camera::ray_direction(int x, int y) const {
  const glm::dvec3 d =
      glm::normalize(glm::dvec3(impl_->world_from_camera * glm::dvec4(core::exact_direction(*impl_, x, y), 0.0)));
  return {d.x, d.y, d.z};
}

Vec3 Camera::ray_origin(int x, int y) const {
  const glm::dvec3 o = core::transform_point(impl_->world_from_camera, core::exact_origin(*impl_, x, y));
  return {o.x, o.y, o.z};
}

bool Camera::is_orthographic() const { return core::is_orthographic(*impl_); }

bool Camera::can_fold_columns() const { return core::can_fold_columns(*impl_); }
bool Camera::can_fold_rows() const { return core::can_fold_rows(*impl_); }

std::string view_file_stem(const std::string& name) { return core::view_file_stem(name); }

std::vector<std::string> view_files(const std::string& pattern, const std::vector<std::optional<std::string>>& names) {
  const size_t field = pattern.find("%s");
  if (field == std::string::npos || pattern.find('%') != field || pattern.find('%', field + 2) != std::string::npos)
    throw InputError(pattern, "may hold one field, %s (the view's name) or %04d (its index)");
  std::vector<std::string> files(names.size());
  std::map<std::string, size_t> first_of;
  for (size_t i = 0; i < names.size(); ++i) {
    if (!names[i]) continue;
    const std::string stem = core::view_file_stem(*names[i]);
    if (stem.empty())
      throw InputError(pattern, "view " + std::to_string(i) + "'s name '" + *names[i] +
                                    "' leaves no file name for %s; name the views by index (%04d)");
    files[i] = pattern.substr(0, field) + stem + pattern.substr(field + 2);
    const auto [at, fresh] = first_of.emplace(files[i], i);
    if (!fresh)
      throw InputError(pattern, "views " + std::to_string(at->second) + " ('" + *names[at->second] + "') and " +
                                    std::to_string(i) + " ('" + *names[i] + "') would both write " + files[i] +
                                    "; name the views by index (%04d)");
  }
  return files;
}

}  // namespace rayfold
