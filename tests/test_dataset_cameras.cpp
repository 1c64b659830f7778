// The dataset importers against hand-made files whose poses are known: a
// camera at (1, 2, 3) looking along world +x, right along +z, up +y, with
// fx = fy = 100, cx = 32, cy = 24 at 64x48, sees the world point
// (11, 2.35, 3.85) (10 ahead, 0.85 right, 0.35 up) at the centre of pixel
// (40, 20): u = 32 + 100 * 0.85 / 10 = 40.5, v = 24 - 100 * 0.35 / 10 = 20.5.
// The same camera written as NeRF (OpenGL axes) and as COLMAP (world to
// camera, OpenCV axes, quaternion (0, sqrt 1/2, 0, sqrt 1/2)) must give that
// pixel's ray through that point.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>

#include <glm/geometric.hpp>

#include "rayfold/camera.h"
#include "rayfold/errors.h"
#include "scene/camera_list.h"
#include "scene/dataset_cameras.h"
#include "test_util.h"
#include "util/errors.h"

namespace rayfold::core {
namespace {

namespace fs = std::filesystem;

fs::path work_dir() {
  const fs::path d =
      testing::scratch_dir("rayfold_dataset") / ::testing::UnitTest::GetInstance()->current_test_info()->name();
  fs::create_directories(d);
  return d;
}

std::string write(const fs::path& p, const std::string& text) {
  std::ofstream(p) << text;
  return p.string();
}

// `text` written to `file` and read by `read` is refused, the message
// holding `message` and naming the file.
void expect_refused(const fs::path& file, const std::string& text, const std::string& message,
                    const std::function<void(const std::string&)>& read) {
  const std::string path = write(file, text);
  try {
    read(path);
    ADD_FAILURE() << "accepted: " << text;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    EXPECT_EQ(e.file(), path);
  }
}

// The world direction of pixel (x, y)'s ray as the tracers make it (the
// double reference's exact direction).
glm::dvec3 pixel_ray(const Camera& c, int x, int y) {
  return glm::normalize(glm::dvec3(c.world_from_camera * glm::dvec4(exact_direction(c, x, y), 0.0)));
}

void expect_sees_the_point(const Camera& c, const std::string& what) {
  const glm::dvec3 eye(c.world_from_camera[3]);
  EXPECT_LT(glm::length(eye - glm::dvec3(1, 2, 3)), 1e-12) << what;
  const glm::dvec3 to_point = glm::normalize(glm::dvec3(11, 2.35, 3.85) - eye);
  EXPECT_LT(glm::length(pixel_ray(c, 40, 20) - to_point), 1e-12) << what;
  EXPECT_GT(glm::length(pixel_ray(c, 41, 20) - to_point), 1e-3) << what << ": the next pixel sees another point";
  EXPECT_EQ(c.width, 64) << what;
  EXPECT_EQ(c.height, 48) << what;
}

const char* const kNerfPose = R"([[0, 0, -1, 1], [0, 1, 0, 2], [1, 0, 0, 3], [0, 0, 0, 1]])";

TEST(DatasetCameras, NerfFramesSeeWhatTheirPosesSay) {
  const fs::path d = work_dir();
  const std::string path = write(d / "transforms.json", std::string(R"({"fl_x": 100, "fl_y": 100, "cx": 32, "cy": 24,
      "w": 64, "h": 48, "aabb_scale": 16, "k1": 0, "p1": 0.0,
      "frames": [{"file_path": "./images/a.png", "transform_matrix": )") + kNerfPose +
                                                             R"(, "sharpness": 30},
                 {"file_path": "b", "fl_x": 50, "transform_matrix": )" + kNerfPose + "}]}");
  std::vector<std::string> ignored;
  const std::vector<DatasetView> views = read_nerf_cameras(path, 0, 0, &ignored);
  ASSERT_EQ(views.size(), 2u);
  expect_sees_the_point(views[0].camera, "frame 0");
  EXPECT_EQ(views[0].name, "./images/a.png");
  EXPECT_EQ(intrinsics(views[1].camera).fx, 50.0);  // the frame's own fl_x
  EXPECT_EQ(intrinsics(views[1].camera).fy, 100.0);
  EXPECT_EQ(ignored, (std::vector<std::string>{"aabb_scale", "sharpness"}));
}

TEST(DatasetCameras, NerfSyntheticFilesTakeTheirSizeFromTheCaller) {
  // The original synthetic scenes: camera_angle_x only, no w, h, cx, cy.
  const fs::path d = work_dir();
  const double angle = 2.0 * std::atan(32.0 / 100.0);  // fx = 0.5 * 64 / tan(angle / 2) = 100
  char text[512];
  std::snprintf(text, sizeof text, R"({"camera_angle_x": %.17g, "frames": [{"file_path": "r_0", "rotation": 0.01,
      "transform_matrix": %s}]})",
                angle, kNerfPose);
  const std::string path = write(d / "transforms_train.json", text);
  const std::vector<DatasetView> views = read_nerf_cameras(path, 64, 48);
  ASSERT_EQ(views.size(), 1u);
  EXPECT_NEAR(intrinsics(views[0].camera).fx, 100.0, 1e-12);
  expect_sees_the_point(views[0].camera, "camera_angle_x");
  try {
    read_nerf_cameras(path);
    FAIL() << "a file without w and h read without a size";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("has no \"w\" and \"h\""), std::string::npos) << e.what();
    EXPECT_EQ(e.file(), path);
  }
}

TEST(DatasetCameras, NerfRefusesDistortionFisheyeAndUnknownKeysByName) {
  const fs::path d = work_dir();
  const std::string frames = std::string(R"("frames": [{"transform_matrix": )") + kNerfPose + "}]";
  const struct {
    std::string text, message;
  } cases[] = {
      {R"({"fl_x": 100, "w": 64, "h": 48, "k1": 0.01, )" + frames + "}", "k1 is a lens distortion"},
      {R"({"fl_x": 100, "w": 64, "h": 48, "camera_model": "OPENCV_FISHEYE", )" + frames + "}",
       "is not a pinhole model"},
      {R"({"fl_x": 100, "w": 64, "h": 48, "is_fisheye": true, )" + frames + "}", "fisheye"},
      {R"({"fl_x": 100, "w": 64, "h": 48, "focal": 3, )" + frames + "}",
       "unknown key \"focal\" (a transforms.json has frames and the intrinsics"},
      {R"({"fl_x": 100, "w": 64, "h": 48, "frames": [{"transform_matrix": )" + std::string(kNerfPose) +
           R"(, "focal": 3}]})",
       "frames[0]: unknown key \"focal\" (a transforms.json frame has"},
      {R"({"fl_x": 100, "w": 64, "h": 48, "frames": [{"transform_matrix": )" + std::string(kNerfPose) +
           R"(, "fl_y": "x"}]})",
       "frames[0].fl_y must be a number"},
      {R"({"w": 64, "h": 48, )" + frames + "}", "has no focal length"},
      {R"({"fl_x": 100, "w": 64, "h": 48, "frames": [{"transform_matrix": [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0],
          [0, 0, 0, 1]]}]})",
       "frames[0]"},
      {R"({"fl_x": 100, "w": 64, "h": 48, "frames": []})", "\"frames\" must be a non-empty array"},
  };
  for (const auto& c : cases)
    expect_refused(d / "t.json", c.text, c.message, [](const std::string& p) { read_nerf_cameras(p); });
}

// A new user's slips, once read without a word: a misspelt key of the list
// (OpenGL poses at 60 degrees), a camera with both kinds of pose
// (camera_to_world won), and broken JSON said to be "not a JSON object".
TEST(DatasetCameras, CameraListsRefuseWhatTheyWouldNotReadSayingWhere) {
  const fs::path d = work_dir();
  const std::string camera = R"({"eye": [0, 0, 5], "look_at": [0, 0, 0]})";
  const std::string matrix = R"("camera_to_world": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 5, 0, 0, 0, 1])";
  const struct {
    std::string text, message;
  } cases[] = {
      {R"({"width": 64, "height": 48, "conventon": "opencv", "cameras": [)" + camera + "]}",
       "unknown key \"conventon\""},
      {R"({"width": 64, "height": 48, "vFov": 20, "cameras": [)" + camera + "]}", "unknown key \"vFov\""},
      {R"({"width": 64, "height": 48, "fl_x": 300, "cameras": [)" + camera + "]}", "unknown key \"fl_x\""},
      {R"({"width": 64, "height": 48, "cameras": [{"eye": [5, 5, 5], "look_at": [0, 0, 0], )" + matrix + "}]}",
       "cameras[0] gives both camera_to_world and \"eye\""},
      {R"({"width": 64, "height": 48, "cameras": [{"up": [0, 0, 1], )" + matrix + "}]}",
       "cameras[0] gives both camera_to_world and \"up\""},
      {R"({"width": 64, "height": 48, "cameras": [)" + camera + ",]}",
       "is not valid JSON: parse error at line 1, column "},
      {"[" + camera + "]", "holds a JSON array, not the object {...} of a camera list"},
  };
  for (const auto& c : cases)
    expect_refused(d / "list.json", c.text, c.message, [](const std::string& p) { read_camera_list(p); });
  // A rayfold-peers report is a list with the benchmark's results beside it.
  EXPECT_EQ(read_camera_list(write(d / "report.json", R"({"width": 64, "height": 48, "scene": "x.glb", "rows": [],
                                                         "machine": {}, "cameras": [)" +
                                                          camera + "]}"))
                .size(),
            1u);
  // Every camera bad: the file once, then the last camera's reason.
  const std::string bad = write(d / "bad.json", R"({"width": 64, "height": 48, "cameras": [{"eye": [0, 0, 5]}]})");
  SkippedViews skipped;
  try {
    read_cameras_any(bad, 0, 0, nullptr, "", &skipped);
    ADD_FAILURE() << "accepted " << bad;
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind(bad + ": has no camera that can be rendered; the last: cameras[0] needs", 0),
              0u)
        << e.what();
  }
  // Each pose alone still reads.
  EXPECT_EQ(read_camera_list(
                write(d / "ok.json", R"({"width": 64, "height": 48, "cameras": [)" + camera + ", {" + matrix + "}]}"))
                .size(),
            2u);
}

TEST(DatasetCameras, ColmapImagesSeeWhatTheirPosesSay) {
  const fs::path d = work_dir();
  write(d / "cameras.txt", "# Camera list with one line of data per camera:\n"
                           "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
                           "1 PINHOLE 64 48 100 100 32 24\n"
                           "2 SIMPLE_PINHOLE 64 48 100 32 24\n");
  const double h = std::sqrt(0.5);
  char images[1024];
  // t = -R eye with R's rows (0, 0, 1), (0, -1, 0), (1, 0, 0): (-3, 2, -1).
  // The second image's 2D-point line is empty, as COLMAP writes it for an
  // image without points.
  std::snprintf(images, sizeof images,
                "# Image list with two lines of data per image:\n"
                "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
                "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
                "# Number of images: 2, mean observations per image: 1\n"
                "7 0 %.17g 0 %.17g -3 2 -1 1 frame one.jpg\n"
                "10.5 20.5 -1\n"
                "9 0 %.17g 0 %.17g -3 2 -1 2 two.jpg\n"
                "\n",
                h, h, h, h);
  write(d / "images.txt", images);
  const std::vector<DatasetView> views = read_colmap_cameras(d.string());
  ASSERT_EQ(views.size(), 2u);
  EXPECT_EQ(views[0].name, "frame one.jpg");
  EXPECT_EQ(views[1].name, "two.jpg");
  expect_sees_the_point(views[0].camera, "PINHOLE");
  expect_sees_the_point(views[1].camera, "SIMPLE_PINHOLE");
}

TEST(DatasetCameras, ColmapRefusesDistortionModelsAndMissingCamerasByName) {
  const fs::path d = work_dir();
  write(d / "images.txt", "1 1 0 0 0 0 0 0 1 a.jpg\n\n");
  write(d / "cameras.txt", "1 SIMPLE_RADIAL 64 48 100 32 24 0.01\n");
  try {
    read_colmap_cameras(d.string());
    ADD_FAILURE() << "SIMPLE_RADIAL accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("SIMPLE_RADIAL, a model with lens distortion"), std::string::npos)
        << e.what();
    EXPECT_EQ(e.file(), (d / "cameras.txt").string());
  }
  write(d / "cameras.txt", "2 PINHOLE 64 48 100 100 32 24\n");
  try {
    read_colmap_cameras(d.string());
    ADD_FAILURE() << "an image of a missing camera accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("names camera 1, which cameras.txt does not have"), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(read_colmap_cameras((d / "nowhere").string()), InputError);
}

// Lenient reading (a batch's): a view whose own entry is bad is listed with
// its index in the file and the reason, the others read as they would
// alone; the file's structure still throws.
TEST(DatasetCameras, LenientReadersListTheBadViewsAndKeepTheRest) {
  const fs::path d = work_dir();
  const std::string nerf = write(d / "t.json", R"({"w": 40, "h": 30, "camera_angle_x": 0.9, "frames": [
      {"file_path": "a", "transform_matrix": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 5], [0, 0, 0, 1]]},
      {"file_path": "b", "transform_matrix": [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 5], [0, 0, 0, 1]]},
      {"file_path": "c", "k1": 0.1, "transform_matrix": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 5], [0, 0, 0, 1]]},
      {"file_path": "d", "transform_matrix": [[1, 0, 0, 1], [0, 1, 0, 0], [0, 0, 1, 5], [0, 0, 0, 1]]}]})");
  EXPECT_THROW(read_nerf_cameras(nerf), InputError);
  SkippedViews skipped;
  const std::vector<DatasetView> views = read_nerf_cameras(nerf, 0, 0, nullptr, &skipped);
  ASSERT_EQ(views.size(), 2u);
  EXPECT_EQ(views[0].name, "a");
  EXPECT_EQ(views[1].name, "d");
  ASSERT_EQ(skipped.size(), 2u);
  EXPECT_EQ(skipped[0].first, 1u);
  EXPECT_NE(skipped[0].second.find("frames[1]"), std::string::npos) << skipped[0].second;
  // The file once, at the start (it was said twice: "t.json: t.json: frames[1]...").
  EXPECT_EQ(skipped[0].second.rfind(nerf + ": frames[1]", 0), 0u) << skipped[0].second;
  EXPECT_EQ(skipped[1].first, 2u);
  EXPECT_NE(skipped[1].second.find("k1"), std::string::npos) << skipped[1].second;

  write(d / "cameras.txt", "1 PINHOLE 64 48 100 100 32 24\n");
  write(d / "images.txt", "1 1 0 0 0 0 0 0 1 a.jpg\n\n2 0 0 0 0 0 0 0 1 b.jpg\n1 2 3\n3 1 0 0 0 0 0 1 7 c.jpg\n\n"
                          "4 1 0 0 0 1 0 0 1 d.jpg\n\n");
  EXPECT_THROW(read_colmap_cameras(d.string()), InputError);
  SkippedViews colmap;
  const std::vector<DatasetView> images = read_colmap_cameras(d.string(), &colmap);
  ASSERT_EQ(images.size(), 2u);
  EXPECT_EQ(images[0].name, "a.jpg");
  EXPECT_EQ(images[1].name, "d.jpg");
  ASSERT_EQ(colmap.size(), 2u);
  EXPECT_EQ(colmap[0].first, 1u);
  EXPECT_NE(colmap[0].second.find("quaternion"), std::string::npos) << colmap[0].second;
  EXPECT_EQ(colmap[1].first, 2u);
  EXPECT_NE(colmap[1].second.find("names camera 7"), std::string::npos) << colmap[1].second;
  // A broken structure is no view's fault.
  write(d / "images.txt", "1 1 0 0 a.jpg\n\n");
  EXPECT_THROW(read_colmap_cameras(d.string(), &colmap), InputError);
}

// The file name a view's name gives under %s: the last component, less its
// extension; nothing for names that have none.
TEST(DatasetCameras, ViewFileStemsKeepTheLastNameWithoutItsExtension) {
  EXPECT_EQ(view_file_stem("./train/r_0"), "r_0");
  EXPECT_EQ(view_file_stem("images/frame.0001.png"), "frame.0001");
  EXPECT_EQ(view_file_stem("a.jpg"), "a");
  EXPECT_EQ(view_file_stem("dir/"), "dir");
  EXPECT_EQ(view_file_stem(".hidden"), ".hidden");
  EXPECT_EQ(view_file_stem("7"), "7");
  for (const char* none : {"", "./", "..", "a/.."}) EXPECT_EQ(view_file_stem(none), "") << none;
}

// The files a %s pattern names, as the CLI and rayfold-batch both check
// them: a view without a name writes nothing, and the error names the
// pattern and both views of a clash.
TEST(DatasetCameras, ViewFilesNameEachViewOnceOrSayWhichTwoClash) {
  using Names = std::vector<std::optional<std::string>>;
  EXPECT_EQ(rayfold::view_files("out/%s.exr", Names{"./train/r_0", std::nullopt, "images/r_1.png"}),
            (std::vector<std::string>{"out/r_0.exr", "", "out/r_1.exr"}));
  auto message = [](const std::string& pattern, const Names& names) {
    try {
      rayfold::view_files(pattern, names);
    } catch (const rayfold::InputError& e) {
      EXPECT_EQ(e.file(), pattern);
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(message("o/%s.exr", Names{"a/same.jpg", "x", "b/same.png"}),
            "o/%s.exr: views 0 ('a/same.jpg') and 2 ('b/same.png') would both write o/same.exr; name the views by "
            "index (%04d)");
  EXPECT_EQ(message("o/%s.exr", Names{"a", "./"}),
            "o/%s.exr: view 1's name './' leaves no file name for %s; name the views by index (%04d)");
  for (const char* pattern : {"o/%s_%04d.exr", "o/%d%s.exr", "o/%s%s.exr", "o/view.exr"})
    EXPECT_NE(message(pattern, Names{"a"}).find("may hold one field, %s"), std::string::npos) << pattern;
}

}  // namespace
}  // namespace rayfold::core
