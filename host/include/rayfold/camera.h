// A pinhole camera: a rigid pose and intrinsics in pixels. Pixel (x, y) has
// its centre at (x + 0.5, y + 0.5) from the image's top-left corner; rows go
// down. Depths are distances from the eye along each pixel's ray.
#pragma once

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rayfold/types.h"

namespace rayfold {
namespace core {
struct Camera;
}

// How a camera-to-world matrix's camera axes point.
enum class CameraConvention {
  opengl,  // +x right, +y up, looking down -z (rayfold's camera space; glTF, Blender, NeRF)
  opencv,  // +x right, +y down, looking down +z (OpenCV, COLMAP)
};

// Pinhole intrinsics in pixels: focal lengths and the principal point, pixel
// centres at +0.5 (an OpenCV calibration, whose centres sit at integers,
// adds 0.5 to cx and cy).
struct Intrinsics {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
};

// A view described as a look-at: what a glTF camera, a view rayfold chose
// (Scene::default_view) and the CLI's --eye, --look-at, --up, --vfov and
// --ortho give; Camera::from_view makes the camera of it at an image size.
struct View {
  Vec3 eye{0.0, 0.0, 1.0};
  Vec3 target{0.0, 0.0, 0.0};
  Vec3 up{0.0, 1.0, 0.0};
  double vfov_degrees = 60.0;  // perspective: the vertical field of view
  bool orthographic = false;
  double half_height = 1.0;  // orthographic: world units above and below the axis
};

class Camera {
 public:
  // From an eye looking at target, +y of the image along up projected onto
  // the view plane, a vertical field of view in degrees (0, 180) and a size
  // of 1..32767 pixels per side; square pixels, centred principal point.
  // Throws InputError for a degenerate view.
  static Camera look_at(const Vec3& eye, const Vec3& target, const Vec3& up, double vfov_degrees, int width,
                        int height);
  // A parallel-axis stereo pair (left, right) around look_at(eye, target,
  // ...): eye and target moved baseline / 2 along the camera's right vector
  // each way, so both look the same way. InputError as look_at, or for a
  // baseline that is not positive and finite.
  static std::array<Camera, 2> stereo_pair(const Vec3& eye, const Vec3& target, const Vec3& up, double vfov_degrees,
                                           int width, int height, double baseline);
  // An orthographic view: parallel rays along the view direction from the
  // plane through eye, the image `half_height` world units above and below
  // the axis (square pixels). Depth is the distance from that plane.
  static Camera orthographic(const Vec3& eye, const Vec3& target, const Vec3& up, double half_height, int width,
                             int height);
  // look_at or orthographic as the view says, its image window moved by
  // shift_x, shift_y half image widths and heights (an off-centre principal
  // point, rounded to whole half pixels so that mirror partners keep exactly
  // negated rays; only the symmetric part folds): at most 100 each way,
  // InputError otherwise.
  static Camera from_view(const View& view, int width, int height, double shift_x = 0.0, double shift_y = 0.0);
  // From a rigid camera-to-world matrix in the named convention (rotations
  // rounded to float are accepted to 1e-5 and made orthonormal; scale, shear
  // and mirrors are InputErrors) and intrinsics. A principal point off the
  // half-pixel grid is exact, but the fold cannot mirror that axis
  // (can_fold_columns, can_fold_rows).
  static Camera from_matrix(const Matrix4& camera_to_world, const Intrinsics& intrinsics, int width, int height,
                            CameraConvention convention);

  // A dataset's cameras with their image names, in the file's order; pinhole
  // only, a distortion model refused by name. from_nerf: a NeRF /
  // instant-ngp transforms.json (OpenGL axes; a file without "w" and "h"
  // takes width x height when they are positive); keys that change no view
  // (aabb_scale, scale, offset, ...) are listed in *ignored, any other
  // unknown key is an InputError. from_colmap: a COLMAP text model in dir
  // (cameras.txt with PINHOLE or SIMPLE_PINHOLE cameras, images.txt).
  static std::vector<std::pair<std::string, Camera>> from_nerf(const std::string& path, int width = 0,
                                                                int height = 0,
                                                                std::vector<std::string>* ignored = nullptr);
  static std::vector<std::pair<std::string, Camera>> from_colmap(
      const std::string& dir, std::vector<std::pair<size_t, std::string>>* skipped = nullptr);
  // A rayfold camera list (the CLI's --cameras FILE.json; the list in
  // docs/cli.md) or a NeRF transforms.json, told apart by content (an object
  // with "frames" and no "cameras" is the latter), with the views' names
  // ("0", "1", ... in a list); width, height and *ignored as from_nerf, a
  // list refuses a size. InputError names the file and what is wrong.
  // With skipped given, from_file and from_colmap leave out a view whose
  // own entry is bad and list it there (its index in the file, the reason)
  // instead of throwing; a bad file structure still throws.
  // size_words: what an error calls width and height (the CLI: "--size").
  static std::vector<std::pair<std::string, Camera>> from_file(
      const std::string& path, int width = 0, int height = 0, std::vector<std::string>* ignored = nullptr,
      std::vector<std::pair<size_t, std::string>>* skipped = nullptr,
      const std::string& size_words = "width and height");

  int width() const;
  int height() const;
  // The pose, camera axes in the convention asked for.
  Matrix4 camera_to_world(CameraConvention convention = CameraConvention::opengl) const;
  Matrix4 world_to_camera(CameraConvention convention = CameraConvention::opengl) const;
  Intrinsics intrinsics() const;
  Vec3 eye() const;
  double vfov_degrees() const;
  // Pixel (x, y)'s ray in world space: a hit at depth d lies at
  // ray_origin(x, y) + d * ray_direction(x, y) (unit length). The origin is
  // the eye, or for an orthographic camera the pixel's point on its plane.
  Vec3 ray_direction(int x, int y) const;
  Vec3 ray_origin(int x, int y) const;
  bool is_orthographic() const;
  // Whether the fold can pair columns (fold y) and rows (fold x): the
  // principal point lies on the half-pixel grid in that axis.
  bool can_fold_columns() const;
  bool can_fold_rows() const;

  // The camera as bytes, every value it holds bit for bit, and back: for
  // sending cameras between processes (Python's pickle, rayfold.batch).
  // from_bytes throws InputError for bytes that are not a camera of this
  // format version.
  std::string to_bytes() const;
  static Camera from_bytes(const std::string& bytes);

  const core::Camera& core() const { return *impl_; }

 private:
  explicit Camera(std::shared_ptr<const core::Camera> impl) : impl_(std::move(impl)) {}
  std::shared_ptr<const core::Camera> impl_;
};

// What a view's name (from_nerf's, from_colmap's, from_file's) gives an
// output file under `%s`: its last path component without its extension
// ("./train/r_0" -> "r_0", "a.jpg" -> "a"), so that every view of a dataset
// lands in one output folder; empty where nothing is left ("", "./", "..").
// The CLI's -o and rayfold-batch name views' files by it.
std::string view_file_stem(const std::string& name);

// Each view's output file under a pattern holding one field, %s: the
// pattern with %s replaced by view_file_stem(names[i]); empty for a view
// without a name (nullopt: one skipped as bad). Throws InputError (the
// pattern) for another field beside %s, for the first view whose name
// leaves no file name and for the first two views that would write one
// file, each view by its index in names. The CLI's -o, --png and --stats
// and rayfold-batch's outputs are named and checked here.
std::vector<std::string> view_files(const std::string& pattern, const std::vector<std::optional<std::string>>& names);

}  // namespace rayfold
