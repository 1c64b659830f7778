// The command-line tool as a user meets it: outputs, exit codes, messages,
// and no file left behind on failure.
#include <gtest/gtest.h>

#include <sys/wait.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include <cstring>

#include <ImfChannelList.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfStringAttribute.h>
#include <ImfStringVectorAttribute.h>
#include <nlohmann/json.hpp>

#include "fixtures/gbuffer_scene.h"
#include "fixtures/gltf_writer.h"
#include "gltf_fixture.h"
#include "output/image_output.h"
#include "rayfold/rayfold.h"
#include "test_util.h"

namespace rayfold::core {
namespace {

namespace fs = std::filesystem;

struct CliRun {
  int code = -1;
  std::string out, err;
};

CliRun rayfold(const std::string& args) {
  const fs::path dir = testing::scratch_dir("rayfold_cli");
  const std::string out = (dir / "stdout").string(), err = (dir / "stderr").string();
  const std::string cmd = std::string(RAYFOLD_BIN) + " " + args + " >" + out + " 2>" + err;
  const int status = std::system(cmd.c_str());
  CliRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
  std::ifstream o(out), e(err);
  r.out.assign(std::istreambuf_iterator<char>(o), {});
  r.err.assign(std::istreambuf_iterator<char>(e), {});
  return r;
}

fs::path work_dir() { return testing::scratch_dir("rayfold_cli_work"); }

TEST(Cli, KernelChoiceIsReportedAndBothKernelsWriteTheSameFile) {
  const fs::path d = work_dir();
  std::vector<std::vector<rf_pixel_hit>> images;
  for (const char* kernel : {"tile", "single"}) {
    const std::string exr = (d / (std::string(kernel) + ".exr")).string();
    const std::string json = (d / (std::string(kernel) + ".json")).string();
    const CliRun r =
        rayfold(std::string("render --size 65x37 --fold xy --kernel ") + kernel + " -o " + exr + " --stats " + json);
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find(std::string("kernel       ") + kernel), std::string::npos) << r.out;
    std::ifstream js(json);
    const std::string text((std::istreambuf_iterator<char>(js)), {});
    EXPECT_NE(text.find(std::string("\"kernel\": \"") + kernel + "\""), std::string::npos) << text;
    int w = 0, h = 0;
    images.push_back(read_exr(exr, &w, &h));
  }
  EXPECT_EQ(testing::compare_hits(images[0], images[1], 65), "");
  // Once reported as the tile kernel: orthographic views trace single rays.
  const std::string ortho = (d / "ortho.json").string();
  const CliRun o = rayfold("render --size 32x18 --ortho 6 --kernel tile --stats " + ortho);
  ASSERT_EQ(o.code, 0) << o.err;
  EXPECT_NE(o.out.find("kernel       single (orthographic"), std::string::npos) << o.out;
  std::ifstream oj(ortho);
  const std::string otext((std::istreambuf_iterator<char>(oj)), {});
  EXPECT_NE(otext.find("\"kernel\": \"single\""), std::string::npos) << otext;
  const CliRun bad = rayfold("render --size 8x8 --kernel wide");
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("--kernel: 'wide' is not tile, single, measure or auto"), std::string::npos) << bad.err;
  const CliRun both = rayfold("render --size 8x8 --backend cpu --kernel tile");
  EXPECT_EQ(both.code, 2);
  EXPECT_NE(both.err.find("--kernel: the CPU backend"), std::string::npos) << both.err;
  const CliRun cpu = rayfold("render --size 8x8 --backend cpu --stats " + (d / "cpu.json").string());
  ASSERT_EQ(cpu.code, 0) << cpu.err;
  EXPECT_NE(cpu.out.find("kernel       cpu reference"), std::string::npos) << cpu.out;
}

TEST(Cli, RenderWritesEverythingAndPrintsTheTable) {
  const fs::path d = work_dir();
  const std::string exr = (d / "a.exr").string(), png = (d / "a.png").string(), json = (d / "a.json").string();
  const CliRun r = rayfold("render --size 96x54 --frames 2 -o " + exr + " --png " + png + " --stats " + json);
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* key : {"BLAS build", "TLAS build", "trace", "Mrays/s", "device", "triangles"})
    EXPECT_NE(r.out.find(key), std::string::npos) << key << " missing from:\n" << r.out;
  int w = 0, h = 0;
  const std::vector<rf_pixel_hit> hits = read_exr(exr, &w, &h);
  EXPECT_EQ(w, 96);
  EXPECT_EQ(h, 54);
  size_t hit = 0;
  for (const rf_pixel_hit& p : hits) hit += p.instance != RF_INVALID;
  EXPECT_GT(hit, hits.size() / 2);
  EXPECT_GT(fs::file_size(png), 100u);
  std::ifstream js(json);
  const std::string text((std::istreambuf_iterator<char>(js)), {});
  for (const char* key : {"\"trace\"", "\"readback\"", "\"upload\"", "\"blas_build\"", "\"tlas_build\"", "\"load\"",
                          "\"nodes\"", "\"triangles\"", "\"hits\""})
    EXPECT_NE(text.find(key), std::string::npos) << key;
  for (const auto& e : fs::directory_iterator(d))
    EXPECT_EQ(e.path().string().find(".rayfold-"), std::string::npos) << "temporary file left: " << e.path();
}

TEST(Cli, CpuAndOpenClWriteIdenticalFiles) {
  const fs::path d = work_dir();
  const std::string a = (d / "cpu.exr").string(), b = (d / "cl.exr").string();
  ASSERT_EQ(rayfold("render --size 64x40 --backend cpu -q -o " + a).code, 0);
  ASSERT_EQ(rayfold("render --size 64x40 --backend opencl -q -o " + b).code, 0);
  int w, h;
  const auto from_a = read_exr(a, &w, &h), from_b = read_exr(b, &w, &h);  // w is set before it is passed
  EXPECT_EQ(testing::compare_hits(from_a, from_b, w), "");
}

TEST(Cli, FoldedFilesEqualUnfoldedFiles) {
  const fs::path d = work_dir();
  const std::string none = (d / "none.exr").string();
  ASSERT_EQ(rayfold("render --size 65x37 --shift 0.2,-0.1 -q -o " + none).code, 0);
  int w, h;
  const std::vector<rf_pixel_hit> ref = read_exr(none, &w, &h);
  for (const char* f : {"y", "x", "xy"}) {
    const std::string out = (d / (std::string("fold_") + f + ".exr")).string();
    ASSERT_EQ(rayfold(std::string("render --size 65x37 --shift 0.2,-0.1 -q --fold ") + f + " -o " + out).code, 0);
    EXPECT_EQ(testing::compare_hits(ref, read_exr(out, &w, &h), w), "") << f;
  }
}

TEST(Cli, CompareAndAnimatePrintTheComparison) {
  const CliRun r = rayfold("render --size 80x45 --frames 2 --compare --animate");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("folded xy"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("identical"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("speed-up"), std::string::npos) << r.out;
}

TEST(Cli, BenchPrintsBothTablesAndWritesReports) {
  const fs::path d = work_dir();
  const std::string json = (d / "b.json").string(), md = (d / "b.md").string();
  const CliRun r = rayfold("bench --size 64x36 --views 2 --frames 1 --warmup 0 --json " + json + " --md " + md);
  ASSERT_EQ(r.code, 0) << r.err;
  for (const char* key : {"Table 1", "Table 2", "none (no culling)", "| xy |", "bit for bit"})
    EXPECT_NE(r.out.find(key), std::string::npos) << key << "\n" << r.out;
  EXPECT_GT(fs::file_size(json), 100u);
  EXPECT_GT(fs::file_size(md), 100u);
}

// Random views in the bench: the report says which views it measured.
TEST(Cli, BenchOnRandomViewsSaysWhichViews) {
  const CliRun r = rayfold("bench --size 64x36 --random-views 2 --seed 9 --frames 1 --warmup 0");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("2 random interior views, seed 9"), std::string::npos) << r.out;
}

TEST(Cli, UsageErrorsExitTwoWithAMessage) {
  for (const char* args : {"render --size 0x10",
                           "render --size -5x10",
                           "render --size 10",
                           "render --bogus",
                           "render --eye 0,0,0",
                           "render --eye 0,0,0 --look-at 0,1,0 --up 0,2,0",
                           "render --vfov 180",
                           "render --frames 0",
                           "frobnicate",
                           "info",
                           "render --fold z",
                           "render --shift 1",
                           "render --shift 1e9,0",
                           "bench --views 0",
                           "bench --bogus",
                           "render --time x",
                           "render --ortho 2 --vfov 30",
                           "render --ortho 0",
                           "render --fps 0",
                           "bench --seed 3",
                           "bench --view-kind object",
                           "bench --random-views 2 --view-kind room",
                           "bench --random-views 2 --eye 0,0,0 --look-at 1,0,0",
                           "bench --random-views 0",
                           "render --exr-compression dwaa",
                           "render --exr-compression zip9"}) {
    const CliRun r = rayfold(args);
    EXPECT_EQ(r.code, 2) << args << "\n" << r.err;
    EXPECT_EQ(r.err.rfind("error: ", 0), 0u) << args << ": " << r.err;
  }
  // The fold's refusal names every word --fold takes.
  const CliRun fold = rayfold("render --fold xz");
  EXPECT_NE(fold.err.find("is not none, y, x, xy or auto"), std::string::npos) << fold.err;
}

TEST(Cli, BadFilesExitTwoNamingTheFile) {
  const fs::path d = work_dir();
  const std::string missing = (d / "nope.glb").string();
  CliRun r = rayfold("render " + missing);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("error: " + missing + ": "), std::string::npos) << r.err;
  const std::string garbage = (d / "garbage.glb").string();
  std::ofstream(garbage) << "glTF but not really";
  r = rayfold("info " + garbage);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find(garbage), std::string::npos) << r.err;
}

// A file where the output's folder should be: missing folders are made,
// but not through a file.
TEST(Cli, UnwritableOutputFailsBeforeTracingAndLeavesNothing) {
  const fs::path d = work_dir();
  std::ofstream(d / "a_file") << "in the way";
  const std::string out = (d / "a_file" / "sub" / "x.exr").string();
  const CliRun r = rayfold("render --size 16x16 -o " + out);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find(out + ": cannot make its folder"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::is_regular_file(d / "a_file"));
}

TEST(Cli, TooLargeForMemoryFailsBeforeAllocatingAndWritesNothing) {
  const fs::path d = work_dir();
  const std::string out = (d / "huge.exr").string();
  for (const char* backend : {"opencl", "cpu"}) {
    const CliRun r = rayfold(std::string("render --size 32767x32767 --backend ") + backend + " -o " + out);
    EXPECT_EQ(r.code, 3) << backend << ": " << r.err;
    EXPECT_NE(r.err.find("MiB"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
}

TEST(Cli, BadSceneWritesNoOutput) {
  const fs::path d = work_dir();
  const std::string bad = (d / "bad.gltf").string(), out = (d / "bad.exr").string();
  std::ofstream(bad) << "{\"asset\": {\"version\": \"2.0\"}, \"nodes\": [{\"mesh\": 4}]}";
  const CliRun r = rayfold("render " + bad + " -o " + out + " --png " + out + ".png");
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_FALSE(fs::exists(out));
  EXPECT_FALSE(fs::exists(out + ".png"));
  for (const auto& e : fs::directory_iterator(d))
    EXPECT_EQ(e.path().string().find(".rayfold-"), std::string::npos) << "temporary file left: " << e.path();
}

TEST(Cli, HelpForEveryCommand) {
  for (const char* args : {"--help", "render --help", "info --help", "bench --help", "devices --help", "devices -h"}) {
    const CliRun r = rayfold(args);
    EXPECT_EQ(r.code, 0) << args;
    EXPECT_NE(r.out.find("usage: rayfold"), std::string::npos) << args;
  }
  // Once missing: what --compare's failure exits with.
  const CliRun render = rayfold("render --help");
  const size_t compare = render.out.find("  --compare");
  ASSERT_NE(compare, std::string::npos) << render.out;
  EXPECT_NE(render.out.substr(compare, render.out.find("  --braid") - compare).find("exit code 3"), std::string::npos)
      << render.out;
}

// docs/cost_model.md: --fold auto on one view probes the 2 kernels at one
// fold, then the 4 folds with each kernel within 2x of the faster: 5 choices
// or 8, each printed with its prediction (the doc once said 8 always).
TEST(Cli, FoldAutoPrintsTheChoicesTheCostModelDocCounts) {
  const CliRun r = rayfold("render --size 64x36 --fold auto");
  ASSERT_EQ(r.code, 0) << r.err;
  size_t lines = 0;
  for (size_t at = r.out.find("ms/view"); at != std::string::npos; at = r.out.find("ms/view", at + 1)) ++lines;
  EXPECT_TRUE(lines == 5 || lines == 8) << lines << " choices:\n" << r.out;
}

TEST(Cli, InfoDescribesTheDefaultScene) {
  const CliRun r = rayfold(std::string("info ") + RAYFOLD_SOURCE_DIR + "/scenes/atrium.glb");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("instances"), std::string::npos);
  EXPECT_NE(r.out.find("bounds"), std::string::npos);
}

TEST(Cli, IdsManifestAndStatsRecordTheViewAndTheNodes) {
  const fs::path d = work_dir();
  const std::string ids = (d / "ids.json").string(), stats = (d / "view.json").string();
  const CliRun r =
      rayfold("render --size 40x30 --eye 0,3,12 --look-at 0,2,0 --fold xy --ids " + ids + " --stats " + stats);
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json m = nlohmann::json::parse(std::ifstream(ids));
  const Scene scene = load_gltf(RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  ASSERT_EQ(m["instances"].size(), scene.instances.size());
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    EXPECT_EQ(m["instances"][i]["id"], i);
    EXPECT_EQ(m["instances"][i]["name"], scene.instances[i].name);
    EXPECT_EQ(m["instances"][i]["mesh_name"], scene.meshes[scene.instances[i].mesh].name);
  }
  EXPECT_EQ(m["miss"], 4294967295u);
  const nlohmann::json s = nlohmann::json::parse(std::ifstream(stats));
  EXPECT_EQ(s["camera"]["eye"], nlohmann::json({0.0, 3.0, 12.0}));
  EXPECT_EQ(s["camera"]["intrinsics"]["cx"], 20.0);
  EXPECT_EQ(s["camera"]["intrinsics"]["cy"], 15.0);
  EXPECT_EQ(s["camera"]["camera_to_world"].size(), 16u);
  EXPECT_EQ(s["pixels"]["hit"].get<int>() + s["pixels"]["miss"].get<int>(), 40 * 30);
  EXPECT_GT(s["pixels"]["hit"].get<int>(), 0);
  EXPECT_EQ(s["fold"], "xy");
  EXPECT_EQ(s["options"]["cull"], true);
  // info lists every id with its node name.
  const CliRun info = rayfold("info");
  ASSERT_EQ(info.code, 2);  // info needs a scene
  const CliRun listed = rayfold(std::string("info ") + RAYFOLD_SOURCE_DIR "/scenes/atrium.glb");
  ASSERT_EQ(listed.code, 0) << listed.err;
  EXPECT_NE(listed.out.find("instance ids"), std::string::npos) << listed.out;
  EXPECT_NE(listed.out.find("    0      mesh 0     floor\n"), std::string::npos) << listed.out;
}

// Dataset intrinsics in a camera list (fx, fy, cx, cy or K, in pixels with
// pixel centres at +0.5): once refused. The same focal length as a vfov gives
// the same bits, K the same as fx..cy, and --stats records what was given.
// NeRF transforms.json through --cameras and COLMAP through --colmap: the same
// pose and intrinsics as a camera list give its image bit for bit (NeRF); a
// COLMAP model of that camera sees the same triangles; ignored keys are
// announced; conflicts are refused.
TEST(Cli, DatasetCamerasRenderAsTheCameraListOfTheirPoses) {
  const fs::path d = work_dir();
  const std::string pose_rows = "[[1, 0, 0, 0], [0, 1, 0, 2], [0, 0, 1, 14], [0, 0, 0, 1]]";
  std::ofstream(d / "list.json") << R"({"width": 40, "height": 30, "fx": 35, "fy": 35, "cx": 20, "cy": 15,
      "cameras": [{"camera_to_world": [1, 0, 0, 0,  0, 1, 0, 2,  0, 0, 1, 14,  0, 0, 0, 1]}]})";
  std::ofstream(d / "transforms.json") << R"({"fl_x": 35, "cx": 20, "cy": 15, "aabb_scale": 4, "frames": [
      {"file_path": "a", "transform_matrix": )" + pose_rows + R"(},
      {"file_path": "b", "transform_matrix": )" + pose_rows + "}]}";
  fs::create_directories(d / "colmap");
  // The same camera in COLMAP's world-to-camera form: R = diag(1, -1, -1)
  // (quaternion (0, 1, 0, 0)), t = -R eye = (0, 2, 14).
  std::ofstream(d / "colmap" / "cameras.txt") << "1 PINHOLE 40 30 35 35 20 15\n";
  std::ofstream(d / "colmap" / "images.txt") << "1 0 1 0 0 0 2 14 1 a.png\n\n";
  CliRun r = rayfold("render --cameras " + (d / "list.json").string() + " -o " + (d / "list.exr").string());
  ASSERT_EQ(r.code, 0) << r.err;
  r = rayfold("render --cameras " + (d / "transforms.json").string() + " --size 40x30 -o " +
              (d / "nerf_%d.exr").string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("transforms.json: ignored aabb_scale"), std::string::npos) << r.err;
  r = rayfold("render --colmap " + (d / "colmap").string() + " -o " + (d / "colmap.exr").string());
  ASSERT_EQ(r.code, 0) << r.err;
  int w = 0, h = 0;
  const auto listed = read_exr((d / "list.exr").string(), &w, &h);
  for (const char* nerf : {"nerf_0.exr", "nerf_1.exr"})
    EXPECT_EQ(testing::compare_hits(listed, read_exr((d / nerf).string(), &w, &h), w), "") << nerf;
  const auto colmap = read_exr((d / "colmap.exr").string(), &w, &h);
  ASSERT_EQ(colmap.size(), listed.size());
  size_t same = 0;
  for (size_t i = 0; i < listed.size(); ++i)
    same += listed[i].instance == colmap[i].instance && listed[i].primitive == colmap[i].primitive;
  EXPECT_GE(same, listed.size() - 2) << "COLMAP's pose sees other triangles";
  // Conflicts and a transforms.json without a size: refused by name.
  r = rayfold("render --colmap " + (d / "colmap").string() + " --size 40x30 -o " + (d / "x.exr").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("--colmap: cameras.txt gives the image sizes"), std::string::npos) << r.err;
  r = rayfold("render --cameras " + (d / "transforms.json").string() + " -o " + (d / "x.exr").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("has no \"w\" and \"h\""), std::string::npos) << r.err;
  r = rayfold("render --cameras " + (d / "list.json").string() + " --size 40x30 -o " + (d / "x.exr").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("--size does not combine with it"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(d / "x.exr"));
}

// --depth planar: Z along the camera's axis, never more than the distance,
// equal to it at the image centre; the header says which Z it is.
TEST(Cli, PlanarDepthIsRecordedAndAtMostTheDistance) {
  const fs::path d = work_dir();
  CliRun r = rayfold("render --size 48x30 -o " + (d / "distance.exr").string());
  ASSERT_EQ(r.code, 0) << r.err;
  r = rayfold("render --size 48x30 --depth planar -o " + (d / "planar.exr").string());
  ASSERT_EQ(r.code, 0) << r.err;
  int w = 0, h = 0;
  const auto dist = read_exr((d / "distance.exr").string(), &w, &h);
  const auto planar = read_exr((d / "planar.exr").string(), &w, &h);
  size_t shorter = 0;
  for (size_t i = 0; i < dist.size(); ++i) {
    if (dist[i].instance == RF_INVALID) continue;
    ASSERT_LE(planar[i].z, dist[i].z * (1 + 1e-6f)) << "pixel " << i;
    shorter += planar[i].z < dist[i].z * (1 - 1e-4f);
  }
  EXPECT_GT(shorter, dist.size() / 2);
  Imf::InputFile in((d / "planar.exr").string().c_str());
  const auto* depth = in.header().findTypedAttribute<Imf::StringAttribute>("rayfold:depth");
  ASSERT_NE(depth, nullptr);
  EXPECT_NE(depth->value().find("--depth planar"), std::string::npos) << depth->value();
  r = rayfold("render --size 48x30 --depth z -o " + (d / "bad.exr").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("--depth: 'distance'"), std::string::npos) << r.err;
}

// --exact-depth: Z from the exact ray, within float rounding of the float
// Z, every other channel the same bits; the header says so; --fast refuses.
TEST(Cli, ExactDepthChangesOnlyZAndIsRecorded) {
  const fs::path d = work_dir();
  CliRun r = rayfold("render --size 48x30 -o " + (d / "float.exr").string());
  ASSERT_EQ(r.code, 0) << r.err;
  r = rayfold("render --size 48x30 --exact-depth --fold xy -o " + (d / "exact.exr").string());
  ASSERT_EQ(r.code, 0) << r.err;
  int w = 0, h = 0;
  const auto plain = read_exr((d / "float.exr").string(), &w, &h);
  const auto exact = read_exr((d / "exact.exr").string(), &w, &h);
  size_t changed = 0;
  for (size_t i = 0; i < plain.size(); ++i) {
    rf_pixel_hit rest = exact[i];
    rest.z = plain[i].z;
    ASSERT_EQ(std::memcmp(&rest, &plain[i], sizeof rest), 0) << "pixel " << i;
    if (plain[i].instance == RF_INVALID) continue;
    ASSERT_NEAR(exact[i].z, plain[i].z, 1e-5f * plain[i].z) << "pixel " << i;
    changed += exact[i].z != plain[i].z;
  }
  EXPECT_GT(changed, 0u);
  Imf::InputFile in((d / "exact.exr").string().c_str());
  const auto* depth = in.header().findTypedAttribute<Imf::StringAttribute>("rayfold:depth");
  ASSERT_NE(depth, nullptr);
  EXPECT_NE(depth->value().find("--exact-depth"), std::string::npos) << depth->value();
  r = rayfold("render --size 48x30 --fast --exact-depth -o " + (d / "bad.exr").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("--exact-depth runs on the exact kernels"), std::string::npos) << r.err;
  r = rayfold("render --size 48x30 --exact-depth --channels N -o " + (d / "bad.exr").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("--channels leaves Z out"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(d / "bad.exr"));
}

// --channels writes only the channels named, with the full file's values.
TEST(Cli, ChannelsWriteOnlyTheChannelsNamed) {
  const fs::path d = work_dir();
  CliRun r = rayfold("render --size 48x30 -o " + (d / "all.exr").string());
  ASSERT_EQ(r.code, 0) << r.err;
  r = rayfold("render --size 48x30 --channels Z,InstanceID -o " + (d / "some.exr").string());
  ASSERT_EQ(r.code, 0) << r.err;
  {
    Imf::InputFile in((d / "some.exr").string().c_str());
    std::vector<std::string> names;
    for (auto c = in.header().channels().begin(); c != in.header().channels().end(); ++c) names.push_back(c.name());
    EXPECT_EQ(names, (std::vector<std::string>{"InstanceID", "Z"}));
  }
  int w = 0, h = 0;
  const auto all = read_exr((d / "all.exr").string(), &w, &h);
  const auto some = read_exr((d / "some.exr").string(), &w, &h);
  ASSERT_EQ(all.size(), some.size());
  for (size_t i = 0; i < all.size(); ++i) {
    ASSERT_EQ(std::memcmp(&all[i].z, &some[i].z, 4), 0) << "pixel " << i;
    ASSERT_EQ(all[i].instance, some[i].instance) << "pixel " << i;
  }
  r = rayfold("render --size 48x30 --channels Z,Depth -o " + (d / "bad.exr").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("unknown channel 'Depth' (depth, normal, barycentrics, instance_id"), std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(d / "bad.exr"));
}

TEST(Cli, CameraListsTakeIntrinsicsInPixels) {
  const fs::path d = work_dir();
  const std::string list = (d / "k.json").string();
  const std::string pose = R"("camera_to_world": [1, 0, 0, 0,  0, 1, 0, 2,  0, 0, 1, 14,  0, 0, 0, 1])";
  const double f = 0.5 * 30 / std::tan(50.0 * M_PI / 360.0);
  char fstr[64];
  std::snprintf(fstr, sizeof fstr, "%.17g", f);
  auto render_list = [&](const std::string& text, const std::string& out) {
    std::ofstream(list) << text;
    return rayfold("render --cameras " + list + " -o " + (d / out).string() + " --stats " +
                   (d / (out + ".json")).string());
  };
  CliRun r = render_list(R"({"width": 40, "height": 30, "vfov": 50, "cameras": [{)" + pose + "}]}", "vfov.exr");
  ASSERT_EQ(r.code, 0) << r.err;
  r = render_list(R"({"width": 40, "height": 30, "cameras": [{)" + pose + R"(, "fx": )" + fstr + R"(, "fy": )" + fstr +
                      R"(, "cx": 20, "cy": 15}]})",
                  "fx.exr");
  ASSERT_EQ(r.code, 0) << r.err;
  r = render_list(R"({"width": 40, "height": 30, "K": [[)" + std::string(fstr) + R"(, 0, 20], [0, )" + fstr +
                      R"(, 15], [0, 0, 1]], "cameras": [{)" + pose + "}]}",
                  "k.exr");
  ASSERT_EQ(r.code, 0) << r.err;
  int w = 0, h = 0;
  const auto by_vfov = read_exr((d / "vfov.exr").string(), &w, &h);
  const auto by_fx = read_exr((d / "fx.exr").string(), &w, &h);
  const auto by_k = read_exr((d / "k.exr").string(), &w, &h);
  EXPECT_EQ(testing::compare_hits(by_vfov, by_fx, w), "");
  EXPECT_EQ(testing::compare_hits(by_fx, by_k, w), "");
  // An off-centre principal point and an eye/look_at pose: recorded as given.
  r = render_list(R"({"width": 40, "height": 30, "cameras": [{"eye": [0, 3, 12], "look_at": [0, 2, 0],
                     "fx": 30, "fy": 31, "cx": 22.5, "cy": 14}]})",
                  "shifted.exr");
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json st = nlohmann::json::parse(std::ifstream(d / "shifted.exr.json"));
  EXPECT_EQ(st["camera"]["intrinsics"], nlohmann::json({{"fx", 30.0}, {"fy", 31.0}, {"cx", 22.5}, {"cy", 14.0}}));
  EXPECT_EQ(st["camera"]["eye"], nlohmann::json({0.0, 3.0, 12.0}));
  // Half a set, two forms, a skewed K: refused by name.
  const std::pair<const char*, const char*> bad[] = {
      {R"("fx": 30, "fy": 30, "cx": 20)", "fx, fy, cx and cy go together; \"cy\" is missing"},
      {R"("fx": 30, "fy": 30, "cx": 20, "cy": 15, "vfov": 40)", "gives both vfov and intrinsics"},
      {R"("K": [30, 1, 20, 0, 30, 15, 0, 0, 1])", "cameras[0].K must be [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]"},
      {R"("fx": -30, "fy": 30, "cx": 20, "cy": 15)", "cameras[0]"}};
  for (const auto& [keys, message] : bad) {
    r = render_list(R"({"width": 40, "height": 30, "cameras": [{)" + pose + ", " + keys + "}]}", "bad.exr");
    EXPECT_EQ(r.code, 2) << keys << ": " << r.err;
    EXPECT_NE(r.err.find(message), std::string::npos) << keys << ": " << r.err;
    EXPECT_FALSE(fs::exists(d / "bad.exr"));
  }
}

// A machine's first use compiles the kernels (about 2 s with PoCL): said
// once, and the second run takes them from the caches (PoCL's and
// rayfold's, both empty before the first run here).
TEST(Cli, FirstUseCompileIsAnnouncedAndCachedAfterwards) {
  const CliRun devices = rayfold("devices");
  if (devices.out.find("Portable Computing Language") == std::string::npos)
    GTEST_SKIP() << "the cache checked here is PoCL's";
  const fs::path cache = work_dir() / "pocl-cache";
  fs::remove_all(cache);
  fs::create_directories(cache);
  const std::string env = "POCL_CACHE_DIR=" + cache.string() + " RAYFOLD_KERNEL_CACHE=" + cache.string() + "/rayfold ";
  auto kernels_ms = [](const std::string& out) {
    const size_t at = out.find("kernels ", out.find("(BLAS"));
    return at == std::string::npos ? -1.0 : std::atof(out.c_str() + at + 8);
  };
  const std::string cmd = std::string(RAYFOLD_BIN) + " render --size 32x18 -v";
  const auto run_with_cache = [&](std::string* out, std::string* err) {
    const fs::path o = cache.parent_path() / "first.out", e = cache.parent_path() / "first.err";
    const int status = std::system((env + cmd + " >" + o.string() + " 2>" + e.string()).c_str());
    std::ifstream oi(o), ei(e);
    out->assign(std::istreambuf_iterator<char>(oi), {});
    err->assign(std::istreambuf_iterator<char>(ei), {});
    return status;
  };
  std::string out1, err1, out2, err2;
  ASSERT_EQ(run_with_cache(&out1, &err1), 0) << err1;
  ASSERT_EQ(run_with_cache(&out2, &err2), 0) << err2;
  EXPECT_NE(err1.find("note: the OpenCL kernels took"), std::string::npos) << err1;
  EXPECT_NE(err1.find("they are cached"), std::string::npos) << err1;
  EXPECT_EQ(err2.find("note: the OpenCL kernels took"), std::string::npos) << err2;
  EXPECT_GT(kernels_ms(out1), 4 * kernels_ms(out2)) << out1 << out2;
  EXPECT_GT(kernels_ms(out2), 0.0) << out2;
}

// Unnamed nodes are "node N" everywhere the docs say: info, --ids (which
// also gives each instance's node index), the EXR header; once they were "".
TEST(Cli, UnnamedNodesAreNamedByTheirIndexEverywhere) {
  const fs::path d = work_dir();
  testing::GltfFile f;
  f.one_triangle();
  f.j["nodes"][0]["name"] = "named";
  f.j["nodes"][0]["translation"] = {0.0, 0.0, -3.0};
  f.j["nodes"].push_back({{"children", {2}}});
  f.j["nodes"].push_back({{"mesh", 0}, {"translation", {1.0, 0.0, -4.0}}});
  f.j["scenes"] = {{{"nodes", {0, 1}}}};
  const std::string path = f.write("cli_unnamed");
  const std::string ids = (d / "unnamed_ids.json").string(), exr = (d / "unnamed.exr").string();
  const CliRun r = rayfold("render " + path + " --size 32x18 --ids " + ids + " -o " + exr);
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json m = nlohmann::json::parse(std::ifstream(ids));
  ASSERT_EQ(m["instances"].size(), 2u) << m.dump();
  EXPECT_EQ(m["instances"][0]["name"], "named");
  EXPECT_EQ(m["instances"][0]["node"], 0);
  EXPECT_EQ(m["instances"][1]["name"], "node 2");
  EXPECT_EQ(m["instances"][1]["node"], 2);
  const CliRun info = rayfold("info " + path);
  ASSERT_EQ(info.code, 0) << info.err;
  EXPECT_NE(info.out.find("    1      mesh 0     node 2\n"), std::string::npos) << info.out;
  Imf::InputFile in(exr.c_str());
  const auto* names = in.header().findTypedAttribute<Imf::StringVectorAttribute>("rayfold:instanceNames");
  ASSERT_NE(names, nullptr);
  EXPECT_EQ(names->value(), (std::vector<std::string>{"named", "node 2"}));
}

// A mesh's missing attribute is found by the first frame that reads it:
// said once for the run (it was lost when only the last frame's warnings
// were printed), and once in --stats (the scene's list and the render's
// hold it both).
TEST(Cli, EveryFramesWarningsAreSaidOnce) {
  const fs::path d = testing::scratch_dir("rayfold_cli_warn");
  const std::string path = (d / "gbuffer.glb").string();
  write_gbuffer_scene(path);
  for (int frames : {1, 3}) {
    const std::string stats = (d / ("s" + std::to_string(frames) + ".json")).string();
    const CliRun r = rayfold("render " + path + " --size 32x24 --channels TexCoord --animate --frames " +
                             std::to_string(frames) + " -o " + (d / "t_%d.exr").string() + " --stats " + stats);
    ASSERT_EQ(r.code, 0) << r.err;
    const std::string said = "2 meshes (mesh 1 ('box'), mesh 2 ('strip')) have no TEXCOORD_0";
    const size_t first = r.err.find(said);
    EXPECT_NE(first, std::string::npos) << frames << " frames: " << r.err;
    EXPECT_EQ(r.err.find(said, first + 1), std::string::npos) << frames << " frames: said twice: " << r.err;
    std::ifstream in(stats);
    const nlohmann::json j = nlohmann::json::parse(in);
    size_t times = 0;
    for (const std::string w : j["warnings"]) times += w.find(said) != std::string::npos;
    EXPECT_EQ(times, 1u) << frames << " frames: " << j["warnings"].dump();
  }
  fs::remove_all(d);
}

TEST(Cli, AnimateFramesEqualTheFilePosedAtTheirTimes) {
  // Two triangles: one turning about y, one moving up and across, over 2 s.
  const fs::path d = work_dir();
  testing::GltfFile f;
  f.one_triangle();
  f.j["nodes"][0]["translation"] = {0.0, 0.0, -3.0};
  f.j["nodes"][0]["scale"] = {4.0, 4.0, 4.0};
  f.j["nodes"].push_back({{"mesh", 0}, {"translation", {3.0, 0.0, -5.0}}, {"scale", {3.0, 3.0, 3.0}}});
  const float times[3] = {0, 1, 2};
  const float turn[12] = {0, 0, 0, 1, 0, 0.70710678f, 0, 0.70710678f, 0, 1, 0, 0};
  const float move[9] = {3, 0, -5, 0, 2, -5, -3, 0, -5};
  const int tin = f.accessor(f.view(times, 12), 5126, "SCALAR", 3);
  f.j["accessors"][tin]["min"] = {0};
  f.j["accessors"][tin]["max"] = {2};
  const int tv = f.accessor(f.view(turn, 48), 5126, "VEC4", 3), mv = f.accessor(f.view(move, 36), 5126, "VEC3", 3);
  f.j["animations"] = {{{"samplers", {{{"input", tin}, {"output", tv}}, {{"input", tin}, {"output", mv}}}},
                        {"channels",
                         {{{"sampler", 0}, {"target", {{"node", 0}, {"path", "rotation"}}}},
                          {{"sampler", 1}, {"target", {{"node", 1}, {"path", "translation"}}}}}}}};
  f.j["scenes"] = {{{"nodes", {0, 1}}}};
  const std::string path = f.write("cli_animated");
  const std::string view = " --size 48x36 --eye 0,1,6 --look-at 0,1,-4 --fold xy ";
  const CliRun played =
      rayfold("render " + path + view + "--animate --fps 2 --frames 5 -o " + (d / "play_%d.exr").string());
  ASSERT_EQ(played.code, 0) << played.err;
  EXPECT_NE(played.err.find("playing the file's animation: 5 frames from 0 s at 2 fps"), std::string::npos)
      << played.err;
  for (int k = 0; k < 5; ++k) {
    const std::string single = (d / ("at_" + std::to_string(k) + ".exr")).string();
    const CliRun posed = rayfold("render " + path + view + "--time " + std::to_string(0.5 * k) + " -o " + single);
    ASSERT_EQ(posed.code, 0) << posed.err;
    int w = 0, h = 0;
    const auto a = read_exr((d / ("play_" + std::to_string(k) + ".exr")).string(), &w, &h);
    const auto b = read_exr(single, &w, &h);
    EXPECT_EQ(testing::compare_hits(b, a, w), "") << "frame " << k;
    if (k == 1) {
      int hits = 0;
      for (const rf_pixel_hit& p : a) hits += p.instance != RF_INVALID;
      EXPECT_GT(hits, 50);
    }
  }
  // With Flow each frame flows to the next frame's pose: the library's
  // render at its time with the flow to the next (the camera from the
  // EXR's header); the last frame has none to go to.
  const CliRun flowed =
      rayfold("render " + path + view + "--animate --fps 2 --frames 4 --channels Z,InstanceID,Flow -o " +
              (d / "flow_%d.exr").string());
  ASSERT_EQ(flowed.code, 0) << flowed.err;
  {
    const rayfold::Scene scene = rayfold::Scene::load(path);
    rayfold::Renderer renderer(scene);
    const unsigned channels = rayfold::kDepth | rayfold::kInstanceId | rayfold::kFlow;
    for (int k = 0; k < 4; ++k) {
      const std::string exr = (d / ("flow_" + std::to_string(k) + ".exr")).string();
      const rayfold::GBuffer got = rayfold::read_exr(exr);
      const rayfold::Camera camera = *rayfold::read_exr_header(exr).camera;
      EXPECT_EQ(rayfold::read_exr_header(exr).time, 0.5 * k) << "frame " << k << "'s time in its header";
      if (k == 3) {
        for (size_t p = 0; p < got.instance_id.size(); ++p)
          ASSERT_EQ(std::isnan(got.flow[2 * p]), got.instance_id[p] != rayfold::kMiss) << "last frame, pixel " << p;
        continue;
      }
      const rayfold::FlowTo next{camera, 0.5 * (k + 1)};
      const rayfold::GBuffer want = renderer.render_at(0.5 * k, camera, rayfold::Fold::xy, channels, &next);
      EXPECT_EQ(rayfold::count_differing_pixels(got, want), 0u) << "frame " << k;
    }
  }
  EXPECT_EQ(rayfold("render " + path + view + "--animate --frames 2 --compare --channels Flow").code, 2);
  // Animated frames differ: an output without a frame field would keep the
  // last, so it is refused; one frame has no next to flow to.
  const CliRun unnamed = rayfold("render " + path + view + "--animate --frames 3 -o " + (d / "one.exr").string());
  EXPECT_EQ(unnamed.code, 2) << unnamed.err;
  EXPECT_NE(unnamed.err.find("--animate renders 3 frames; name them with a frame field"), std::string::npos)
      << unnamed.err;
  EXPECT_FALSE(fs::exists(d / "one.exr"));
  const CliRun png = rayfold("render " + path + view + "--animate --frames 2 -o " + (d / "f_%d.exr").string() +
                             " --png " + (d / "one.png").string());
  EXPECT_EQ(png.code, 2) << png.err;
  const CliRun alone =
      rayfold("render " + path + view + "--animate --channels Z,Flow -o " + (d / "alone.exr").string());
  EXPECT_EQ(alone.code, 2) << alone.err;
  EXPECT_NE(alone.err.find("one frame (--frames 1) has none to go to"), std::string::npos) << alone.err;
  // Auto-framed: once --time T was framed at T and --animate at its first
  // frame, so the two disagreed; both now frame the pose at time 0.
  const std::string framed = " --size 48x36 --fold xy ";
  const CliRun auto_played =
      rayfold("render " + path + framed + "--animate --fps 2 --frames 5 -o " + (d / "auto_%d.exr").string());
  ASSERT_EQ(auto_played.code, 0) << auto_played.err;
  for (int k : {2, 4}) {
    const std::string single = (d / ("auto_at_" + std::to_string(k) + ".exr")).string();
    const CliRun posed = rayfold("render " + path + framed + "--time " + std::to_string(0.5 * k) + " -o " + single);
    ASSERT_EQ(posed.code, 0) << posed.err;
    int w = 0, h = 0;
    const auto alone = read_exr(single, &w, &h);
    const auto played_k = read_exr((d / ("auto_" + std::to_string(k) + ".exr")).string(), &w, &h);
    EXPECT_EQ(testing::compare_hits(alone, played_k, w), "") << "auto-framed frame " << k;
  }
}

// On a terminal the progress line is erased before every line of output;
// once the first view line was printed onto it ("tracing 0%  0.4 srayfold").
TEST(Cli, TheProgressLineNeverSharesALineWithOutput) {
  if (std::system("command -v script >/dev/null 2>&1") != 0) GTEST_SKIP() << "no script(1) to make a terminal";
  const fs::path d = work_dir();
  const std::string list = (d / "progress.json").string();
  std::ofstream(list) << R"({"width": 32, "height": 18, "cameras": [
      {"eye": [0, 3, 12], "look_at": [0, 2, 0]}, {"eye": [1, 3, 12], "look_at": [0, 2, 0]},
      {"eye": [2, 3, 12], "look_at": [0, 2, 0]}]})";
  const std::string log = (d / "tty.log").string();
  const std::string cmd =
      "script -qec '" + std::string(RAYFOLD_BIN) + " render --cameras " + list + " --align 1' /dev/null > " + log;
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream in(log);
  const std::string text((std::istreambuf_iterator<char>(in)), {});
  ASSERT_NE(text.find("tracing"), std::string::npos) << "no progress line drawn: " << text;
  size_t lines = 0;
  for (const char* start : {"rayfold render", "  pass ", "    view ", "  3 views in 3 passes: trace"})
    for (size_t at = text.find(start); at != std::string::npos; at = text.find(start, at + 1)) {
      ++lines;
      const size_t line_start = text.find_last_of('\n', at);
      const std::string before = text.substr(line_start == std::string::npos ? 0 : line_start + 1,
                                             at - (line_start == std::string::npos ? 0 : line_start + 1));
      const bool erased = before.empty() || before == "\r" ||
                          (before.size() >= 4 && before.compare(before.size() - 4, 4, "\r\033[K") == 0);
      EXPECT_TRUE(erased) << "'" << start << "' printed after: " << before;
    }
  EXPECT_GE(lines, 8u) << text;
}

TEST(Cli, CameraListsAndStereoPairsRenderEachViewAsAloneBitForBit) {
  const fs::path d = work_dir();
  const std::string list = (d / "views.json").string();
  std::ofstream(list) << R"({"width": 40, "height": 30, "vfov": 50, "cameras": [
      {"eye": [0, 3, 12], "look_at": [0, 2, 0]},
      {"eye": [-8, 5, 4], "look_at": [2, 1, -1], "up": [0.1, 1, 0], "vfov": 70},
      {"camera_to_world": [1, 0, 0, 0,  0, 1, 0, 2,  0, 0, 1, 14,  0, 0, 0, 1]}]})";
  CliRun r = rayfold("render --cameras " + list + " --fold xy -o " + (d / "view_%02d.exr").string() + " --stats " +
                     (d / "view_%02d.json").string());
  ASSERT_EQ(r.code, 0) << r.err;
  // Views 0 and 2 share their intrinsics and trace together; view 1's
  // field of view puts it in a pass of its own.
  EXPECT_NE(r.out.find("3 views in 2 passes (--align all)"), std::string::npos) << r.out;
  // Once each view's --stats said 1280x720, load 0, and the pass's trace
  // time as if the view's own; the console repeated it on every view line.
  for (int k = 0; k < 3; ++k) {
    const nlohmann::json s = nlohmann::json::parse(std::ifstream(d / ("view_0" + std::to_string(k) + ".json")));
    EXPECT_EQ(s["width"], 40) << k;
    EXPECT_EQ(s["height"], 30) << k;
    EXPECT_GT(s["times_ms"]["load"].get<double>(), 0.0) << k;
    EXPECT_EQ(s["pass"]["views"], k == 1 ? 1 : 2) << k;
    EXPECT_EQ(s["pass"]["index"], k == 1 ? 1 : 0) << k;
  }
  EXPECT_NE(r.out.find("pass 1 of 2: 2 views, trace "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("pass 2 of 2: 1 view, trace "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("3 views in 2 passes: trace "), std::string::npos) << r.out;
  for (size_t at = r.out.find("    view "); at != std::string::npos; at = r.out.find("    view ", at + 1))
    EXPECT_EQ(r.out.substr(at, r.out.find('\n', at) - at).find(" ms"), std::string::npos) << r.out;
  // Each view alone (--align 1) writes the same bits as the aligned passes.
  CliRun one = rayfold("render --cameras " + list + " --fold xy --align 1 -o " + (d / "one_%02d.exr").string());
  ASSERT_EQ(one.code, 0) << one.err;
  EXPECT_NE(one.out.find("3 views in 3 passes (--align 1)"), std::string::npos) << one.out;
  // "" when the three views written as a_0k.exr and b_0k.exr agree bit for bit.
  auto same_views = [&](const std::string& a, const std::string& b) {
    std::string out;
    for (int k = 0; k < 3; ++k) {
      int w = 0, h = 0;
      const std::string n = "_0" + std::to_string(k) + ".exr";
      const auto from_a = read_exr((d / (a + n)).string(), &w, &h), from_b = read_exr((d / (b + n)).string(), &w, &h);
      const std::string diff = testing::compare_hits(from_a, from_b, w);
      if (!diff.empty()) out += "view " + std::to_string(k) + ": " + diff + "\n";
    }
    return out;
  };
  EXPECT_EQ(same_views("one", "view"), "");
  // The cost model's choice (--fold auto, --align auto): printed, and the
  // same bits again.
  CliRun chosen =
      rayfold("render --cameras " + list + " --fold auto --align auto -o " + (d / "auto_%02d.exr").string());
  ASSERT_EQ(chosen.code, 0) << chosen.err;
  EXPECT_NE(chosen.out.find("auto: "), std::string::npos) << chosen.out;
  EXPECT_NE(chosen.out.find("ms/view"), std::string::npos) << chosen.out;
  EXPECT_EQ(same_views("one", "auto"), "");
  EXPECT_EQ(rayfold("render --fold auto --compare").code, 2);
  // Once silently traced xy: naming none with --compare is a usage error.
  const CliRun none = rayfold("render --size 16x16 --fold none --compare");
  EXPECT_EQ(none.code, 2);
  EXPECT_NE(none.err.find("--compare --fold none"), std::string::npos) << none.err;
  EXPECT_EQ(rayfold("render --cameras " + list + " --align 0").code, 2);
  EXPECT_EQ(rayfold("render --fold sideways").code, 2);
  EXPECT_EQ(rayfold("render --cameras " + list + " --align 33").code, 2);
  const CliRun lone = rayfold("render --align 2");
  EXPECT_EQ(lone.code, 2);
  EXPECT_NE(lone.err.find("--align: aligns the views of --cameras or --stereo"), std::string::npos) << lone.err;
  const std::string singles[] = {"--eye 0,3,12 --look-at 0,2,0 --vfov 50",
                                 "--eye -8,5,4 --look-at 2,1,-1 --up 0.1,1,0 --vfov 70",
                                 "--eye 0,2,14 --look-at 0,2,13 --vfov 50"};
  for (int k = 0; k < 3; ++k) {
    const std::string alone = (d / ("alone_" + std::to_string(k) + ".exr")).string();
    ASSERT_EQ(rayfold("render --size 40x30 " + singles[k] + " -o " + alone).code, 0);
    int w = 0, h = 0;
    const auto a = read_exr((d / ("view_0" + std::to_string(k) + ".exr")).string(), &w, &h);
    const auto b = read_exr(alone, &w, &h);
    if (k < 2) {
      EXPECT_EQ(testing::compare_hits(b, a, w), "") << "view " << k;
    } else {
      // A matrix camera: the same view up to the rounding of its rays.
      size_t same = 0;
      for (size_t i = 0; i < a.size(); ++i) same += a[i].instance == b[i].instance;
      EXPECT_GE(same, a.size() - 3) << "view 2";
    }
  }
  const nlohmann::json s = nlohmann::json::parse(std::ifstream(d / "view_02.json"));
  EXPECT_EQ(s["camera"]["eye"], nlohmann::json({0.0, 2.0, 14.0}));
  // Errors name the list and the member.
  std::ofstream(list) << R"({"width": 40, "height": 30, "cameras": [{"eye": [0, 3], "look_at": [0, 2, 0]}]})";
  r = rayfold("render --cameras " + list + " -o " + (d / "x_%d.exr").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("views.json: cameras[0].eye must be an array of 3 numbers"), std::string::npos) << r.err;
  std::ofstream(list) << R"({"width": 40, "height": 30, "cameras": [{"eye": [0, 3, 1], "look_at": [0, 3, 1]}]})";
  r = rayfold("render --cameras " + list);
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("views.json: cameras[0]: eye and look-at must be distinct"), std::string::npos) << r.err;
  // Once silently rendered at the list's vfov: typos are named.
  for (const char* key : {"lookat", "focal"}) {
    std::ofstream(list) << R"({"width": 40, "height": 30, "cameras": [{"eye": [0, 3, 1], "look_at": [0, 2, 0]},
                               {"eye": [0, 3, 2], "look_at": [0, 2, 0], ")"
                        << key << R"(": 500}]})";
    r = rayfold("render --cameras " + list);
    EXPECT_EQ(r.code, 2) << key;
    EXPECT_NE(r.err.find(std::string("views.json: cameras[1]: unknown key \"") + key + "\""), std::string::npos)
        << r.err;
  }
  std::ofstream(list) << R"({"width": 40, "height": 30, "cameras": [{"eye": [0, 3, 1], "look_at": [0, 2, 0]},
                                                                   {"eye": [0, 3, 2], "look_at": [0, 2, 0]}]})";
  r = rayfold("render --cameras " + list + " -o " + (d / "plain.exr").string());
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("needs a view field such as %04d (the view's index) or %s (its name) for 2 views"), std::string::npos) << r.err;

  // A stereo pair: the eyes 0.5 apart along the camera's right vector.
  r = rayfold("render --size 40x30 --eye 0,3,12 --look-at 0,2,0 --stereo 0.5 -o " + (d / "eye.exr").string());
  ASSERT_EQ(r.code, 0) << r.err;
  CameraSpec centre;
  centre.eye = glm::dvec3(0, 3, 12);
  centre.look_at = glm::dvec3(0, 2, 0);
  const glm::dvec3 right(make_camera(centre, 40, 30).world_from_camera[0]);
  for (const auto& [sign, label] : {std::pair{-0.25, "left"}, std::pair{0.25, "right"}}) {
    const glm::dvec3 e = centre.eye + sign * right, l = centre.look_at + sign * right;
    char args[256];
    std::snprintf(args, sizeof args, "--eye %.17g,%.17g,%.17g --look-at %.17g,%.17g,%.17g", e.x, e.y, e.z, l.x, l.y,
                  l.z);
    const std::string alone = (d / (std::string("alone_") + label + ".exr")).string();
    ASSERT_EQ(rayfold("render --size 40x30 " + std::string(args) + " -o " + alone).code, 0);
    int w = 0, h = 0;
    EXPECT_EQ(testing::compare_hits(read_exr(alone, &w, &h),
                                    read_exr((d / (std::string("eye-") + label + ".exr")).string(), &w, &h), w),
              "")
        << label;
  }
  EXPECT_EQ(rayfold("render --stereo 0.5 --cameras " + list).code, 2);
  EXPECT_EQ(rayfold("render --stereo 0.5 --animate").code, 2);
}

TEST(Cli, OutputExtensionsMustMatchTheirKind) {
  const fs::path d = work_dir();
  for (const std::string& args : {"-o " + (d / "x.png").string(), "--png " + (d / "x.exr").string(),
                                  "-o " + (d / "same.exr").string() + " --stats " + (d / "same.exr").string(),
                                  "--stats " + (d / "s.txt").string()}) {
    const CliRun r = rayfold("render --size 8x8 " + args);
    EXPECT_EQ(r.code, 2) << args;
    EXPECT_NE(r.err.find("must end in"), std::string::npos) << args << ": " << r.err;
  }
  EXPECT_FALSE(fs::exists(d / "x.png"));
  EXPECT_FALSE(fs::exists(d / "same.exr"));
  const CliRun none = rayfold("render --size 8x8");
  EXPECT_EQ(none.code, 0) << none.err;
  EXPECT_NE(none.out.find("nothing written"), std::string::npos) << none.out;
}

TEST(Cli, ScenesThatAreNotGltfFilesExitTwoNamingTheFile) {
  const fs::path d = work_dir();
  const std::string obj = (d / "mesh.obj").string(), dir = (d / "a_directory").string();
  std::ofstream(obj) << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
  fs::create_directories(dir);
  for (auto [path, why] :
       {std::pair{obj, std::string("not a glTF file but an OBJ file")}, {dir, std::string("is a directory")}}) {
    for (const std::string command : {"render ", "info "}) {
      const CliRun r = rayfold(command + path);
      EXPECT_EQ(r.code, 2) << command << path;
      EXPECT_NE(r.err.find("error: " + path + ": " + why), std::string::npos) << r.err;
    }
  }
}

TEST(Cli, VersionDevicesAndDeviceErrors) {
  CliRun r = rayfold("--version");
  EXPECT_EQ(r.code, 0);
  EXPECT_EQ(r.out.rfind("rayfold ", 0), 0u) << r.out;
  EXPECT_EQ(rayfold("devices --all").code, 2);
  r = rayfold("devices");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("compute units"), std::string::npos) << r.out;
  const std::string device_line = r.out.substr(r.out.find('\n') + 1);
  r = rayfold("render --size 8x8 --device no-such-device-anywhere");
  EXPECT_EQ(r.code, 3);
  EXPECT_NE(r.err.find("no OpenCL device matches"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(device_line.substr(0, device_line.find('('))), std::string::npos)
      << "the devices are listed: " << r.err;
  r = rayfold("render --size 8x8 --backend cpu --device pthread");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--device"), std::string::npos) << r.err;
}

TEST(Cli, CommandLineCameraIsUprightWithoutUp) {
  // A file whose camera is rolled 90 degrees: --eye and --look-at replace the
  // camera whole, +Y up, as the help says; --up alone turns the file's.
  testing::GltfFile f;
  f.one_triangle();
  f.j["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", 1.0}, {"znear", 0.01}}}}};
  // Rolled: the camera's +y points along world -x.
  f.j["nodes"].push_back({{"camera", 0}, {"matrix", {0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 1, 0, 0.3, 0.3, 3, 1}}});
  f.j["scenes"] = {{{"nodes", {0, 1}}}};
  const std::string scene = f.write("rolled_camera");
  const fs::path d = work_dir();
  const std::string a = (d / "no_up.exr").string(), b = (d / "up.exr").string(), c = (d / "file.exr").string();
  const std::string view = " --size 24x16 --eye 0.3,0.3,3 --look-at 0.3,0.3,0 ";
  ASSERT_EQ(rayfold("render " + scene + view + "-o " + a).code, 0);
  ASSERT_EQ(rayfold("render " + scene + view + "--up 0,1,0 -o " + b).code, 0);
  ASSERT_EQ(rayfold("render " + scene + " --size 24x16 -o " + c).code, 0);
  int w = 0, h = 0;
  const auto no_up = read_exr(a, &w, &h), up = read_exr(b, &w, &h), file = read_exr(c, &w, &h);
  EXPECT_EQ(testing::compare_hits(no_up, up, 24), "");
  EXPECT_NE(testing::compare_hits(no_up, file, 24), "") << "the file's rolled camera must differ";
}

TEST(Cli, AutoFramedCameraIsPrintedAndReusable) {
  testing::GltfFile f;
  f.one_triangle();
  const std::string scene = f.write("no_camera");
  const fs::path d = work_dir();
  const std::string a = (d / "auto.exr").string(), b = (d / "again.exr").string();
  const CliRun r = rayfold("render " + scene + " --size 20x12 -o " + a);
  ASSERT_EQ(r.code, 0) << r.err;
  const size_t at = r.out.find("auto-framed");
  ASSERT_NE(at, std::string::npos) << r.out;
  const std::string line = r.out.substr(at + 11, r.out.find('\n', at) - at - 11);
  ASSERT_EQ(rayfold("render " + scene + " --size 20x12 " + line + " -o " + b).code, 0) << line;
  int w = 0, h = 0;
  EXPECT_EQ(testing::compare_hits(read_exr(a, &w, &h), read_exr(b, &w, &h), 20), "") << line;
}

// A dataset names its frames: -o out/%s.exr writes each view under its
// name (a COLMAP image's, a transforms.json's file_path, less folders and
// extension), the bits of the view written by index; two names that end
// alike are refused naming both views, and nothing is left behind.
TEST(Cli, DatasetViewsAreWrittenUnderTheirNames) {
  const fs::path d = work_dir() / "named";
  fs::create_directories(d / "model");
  std::ofstream(d / "model" / "cameras.txt") << "1 PINHOLE 40 30 35 35 20 15\n";
  std::ofstream(d / "model" / "images.txt") << "1 0 1 0 0 0 2 14 1 imgs/left.jpg\n\n"
                                               "2 0 1 0 0 1 2 14 1 right.png\n\n";
  const std::string model = (d / "model").string();
  CliRun r = rayfold("render --colmap " + model + " -o " + (d / "named" / "%s.exr").string());
  ASSERT_EQ(r.code, 0) << r.err;
  r = rayfold("render --colmap " + model + " -o " + (d / "indexed" / "%d.exr").string());
  ASSERT_EQ(r.code, 0) << r.err;
  int w = 0, h = 0;
  for (auto [name, index] : {std::pair{"left", "0"}, {"right", "1"}})
    EXPECT_EQ(testing::compare_hits(read_exr((d / "named" / (std::string(name) + ".exr")).string(), &w, &h),
                                    read_exr((d / "indexed" / (std::string(index) + ".exr")).string(), &w, &h), w),
              "")
        << name;
  std::ofstream(d / "model" / "images.txt") << "1 0 1 0 0 0 2 14 1 a/same.jpg\n\n"
                                               "2 0 1 0 0 1 2 14 1 b/same.png\n\n";
  r = rayfold("render --colmap " + model + " -o " + (d / "clash" / "%s.exr").string());
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("views 0 ('a/same.jpg') and 1 ('b/same.png') would both write"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(d / "clash"));
}

// A room without a camera was framed from outside: a closed box. Now the
// view is chosen from inside (pipeline/auto_frame.h), said, and printed as
// options that give the same view again.
TEST(Cli, AnAutoFramedInteriorIsSeenFromInside) {
  Scene hall;
  hall.meshes.push_back(testing::wound_box(true, glm::vec3(5.0f, 1.0f, 1.0f)));
  hall.instances.push_back(Instance{});
  const fs::path d = work_dir();
  const std::string file = (d / "hall.glb").string(), exr = (d / "hall.exr").string();
  write_glb(hall, file);
  const CliRun r = rayfold("render " + file + " --size 32x18 -o " + exr);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("chosen: an interior, seen from inside"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--eye 0,0,0 "), std::string::npos) << r.out;
  int w = 0, h = 0;
  const std::vector<rf_pixel_hit> hits = read_exr(exr, &w, &h);
  for (size_t i = 0; i < hits.size(); ++i) ASSERT_NE(hits[i].instance, RF_INVALID) << "pixel " << i << " missed";
}

// Once silent: the stand-in motion for a file without animations is said,
// also with -q.
TEST(Cli, AnimateWithoutAnimationsSaysWhatMovesInstead) {
  testing::GltfFile f;
  f.one_triangle();
  const std::string path = f.write("still");
  for (const char* quiet : {"", " -q"}) {
    const CliRun r = rayfold("render " + path + " --size 8x8 --frames 2 --animate" + quiet);
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("warning: --animate: " + path + " has no animations"), std::string::npos) << r.err;
  }
  const CliRun plain = rayfold("render " + path + " --size 8x8");
  EXPECT_EQ(plain.err.find("--animate"), std::string::npos) << plain.err;
}

TEST(Cli, OneWarningLinePerKind) {
  testing::GltfFile f;
  f.one_triangle();
  for (int i = 0; i < 5; ++i) f.j["nodes"].push_back({{"mesh", 0}, {"scale", {0, 0, 0}}});
  f.j["scenes"] = {{{"nodes", {0, 1, 2, 3, 4, 5}}}};
  const CliRun r = rayfold("render " + f.write("zero_scales") + " --size 8x8");
  EXPECT_EQ(r.code, 0) << r.err;
  size_t lines = 0;
  for (size_t p = r.err.find("zero scale"); p != std::string::npos; p = r.err.find("zero scale", p + 1)) ++lines;
  EXPECT_EQ(lines, 1u) << r.err;
  EXPECT_NE(r.err.find("(and 4 more like it)"), std::string::npos) << r.err;
  // Once hidden by -q and left out of --stats: the loader's warnings.
  const std::string stats = (testing::temp_dir() / "zero_scales_stats.json").string();
  const CliRun q = rayfold("render " + f.write("zero_scales") + " --size 8x8 -q --stats " + stats);
  EXPECT_EQ(q.code, 0) << q.err;
  EXPECT_EQ(q.out, "");
  EXPECT_NE(q.err.find("zero scale"), std::string::npos) << q.err;
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(stats));
  ASSERT_FALSE(j["warnings"].empty());
  EXPECT_NE(j["warnings"][0].get<std::string>().find("zero scale"), std::string::npos) << j["warnings"];
}

TEST(Cli, SceneAndCameraOptionsAndInfoListsThem) {
  testing::GltfFile f;
  f.one_triangle();
  f.j["cameras"] = {{{"type", "perspective"}, {"perspective", {{"yfov", 0.5}, {"znear", 0.1}}}},
                    {{"type", "perspective"}, {"perspective", {{"yfov", 0.8}, {"znear", 0.1}}}}};
  f.j["nodes"].push_back({{"camera", 0}, {"name", "near"}, {"translation", {0.3, 0.3, 2}}});
  f.j["nodes"].push_back({{"camera", 1}, {"name", "far"}, {"translation", {0.3, 0.3, 9}}});
  f.j["scenes"] = {{{"nodes", {0, 1, 2}}, {"name", "main"}}, {{"nodes", {1}}, {"name", "empty"}}};
  const std::string scene = f.write("cli_scenes");
  CliRun r = rayfold("info " + scene);
  EXPECT_EQ(r.code, 0) << r.err;
  for (const char* text : {"scene 0     main  [shown", "scene 1     empty", "camera 0    node 1 'near'", "camera 1"})
    EXPECT_NE(r.out.find(text), std::string::npos) << text << " in:\n" << r.out;
  const fs::path d = work_dir();
  const std::string a = (d / "cam0.exr").string(), b = (d / "cam1.exr").string(), c = (d / "default.exr").string();
  ASSERT_EQ(rayfold("render " + scene + " --size 16x16 --camera 0 -o " + a).code, 0);
  ASSERT_EQ(rayfold("render " + scene + " --size 16x16 --camera 1 -o " + b).code, 0);
  ASSERT_EQ(rayfold("render " + scene + " --size 16x16 -o " + c).code, 0);
  int w = 0, h = 0;
  EXPECT_EQ(testing::compare_hits(read_exr(a, &w, &h), read_exr(c, &w, &h), 16), "") << "camera 0 is the default";
  EXPECT_NE(testing::compare_hits(read_exr(a, &w, &h), read_exr(b, &w, &h), 16), "") << "camera 1 sees otherwise";
  r = rayfold("render " + scene + " --size 16x16 --scene 1");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("no triangles"), std::string::npos) << "scene 1 holds only a camera: " << r.err;
  r = rayfold("render " + scene + " --size 16x16 --camera 7");
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("camera 7 does not exist"), std::string::npos) << r.err;
}

TEST(Cli, FrameSequencesWriteEveryFrame) {
  const fs::path d = work_dir() / "sequence";
  fs::create_directories(d);
  const std::string pattern = (d / "frame_%04d.exr").string(), single = (d / "single.exr").string();
  CliRun r = rayfold("render --size 40x24 --animate --frames 3 -o " + pattern + " --png " + (d / "p%d.png").string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("frame_0000.exr .. " + (d / "frame_0002.exr").string() + " (3 frames)"), std::string::npos)
      << r.out;
  ASSERT_EQ(rayfold("render --size 40x24 --animate -o " + single).code, 0);
  int w = 0, h = 0;
  std::vector<std::vector<rf_pixel_hit>> frames;
  for (const char* f : {"frame_0000.exr", "frame_0001.exr", "frame_0002.exr"})
    frames.push_back(read_exr((d / f).string(), &w, &h));
  for (const char* f : {"p0.png", "p1.png", "p2.png"}) EXPECT_TRUE(fs::exists(d / f)) << f;
  EXPECT_FALSE(fs::exists(d / "frame_0003.exr"));
  EXPECT_EQ(testing::compare_hits(frames[0], read_exr(single, &w, &h), 40), "")
      << "frame 0 is the first animated frame";
  EXPECT_NE(testing::compare_hits(frames[0], frames[1], 40), "") << "the animation moves";
  EXPECT_NE(testing::compare_hits(frames[1], frames[2], 40), "") << "the animation moves";
  for (const char* bad : {"x_%s.exr", "x_%d_%d.exr", "x_%.exr"}) {
    r = rayfold("render --size 8x8 -o " + (d / bad).string());
    EXPECT_EQ(r.code, 2) << bad;
    EXPECT_NE(r.err.find("one frame field"), std::string::npos) << r.err;
  }
}

TEST(Cli, ProgressOnlyOnATerminalAndVerboseStages) {
  // Captured (not a terminal): no progress line, no carriage return.
  CliRun r = rayfold("render --size 32x24 --frames 2 -v");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.err.find('\r'), std::string::npos) << r.err;
  EXPECT_NE(r.out.find("stages       load"), std::string::npos) << r.out;
  // The writes are timed too (once 7 of 8.5 s at 6000x4000 went unreported).
  const CliRun w = rayfold("render --size 32x24 -v -o " + (work_dir() / "verbose.exr").string());
  ASSERT_EQ(w.code, 0) << w.err;
  EXPECT_NE(w.out.find("), writing "), std::string::npos) << w.out;
  EXPECT_NE(r.out.find("frame 1      cull"), std::string::npos) << r.out;
  // On a terminal (script(1) gives the command one): the stages appear,
  // and with -q nothing does.
  if (std::system("command -v script >/dev/null 2>&1") != 0) GTEST_SKIP() << "script(1) not installed";
  const fs::path d = work_dir();
  const std::string log = (d / "tty.log").string();
  const std::string cmd = "script -qec '" + std::string(RAYFOLD_BIN) + " render --size 32x24 --frames 3 -o " +
                          (d / "tty_%d.exr").string() + "' /dev/null > " + log;
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::ifstream in(log);
  const std::string tty((std::istreambuf_iterator<char>(in)), {});
  EXPECT_NE(tty.find("\033[Ktracing"), std::string::npos) << tty;
  EXPECT_NE(tty.find("%"), std::string::npos) << tty;
  const std::string quiet_cmd =
      "script -qec '" + std::string(RAYFOLD_BIN) + " render --size 32x24 -q' /dev/null > " + log;
  ASSERT_EQ(std::system(quiet_cmd.c_str()), 0);
  std::ifstream qin(log);
  const std::string quiet((std::istreambuf_iterator<char>(qin)), {});
  EXPECT_EQ(quiet.find("tracing"), std::string::npos) << quiet;
}

}  // namespace
}  // namespace rayfold::core
