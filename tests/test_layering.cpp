// The library's stages include only stages below them: the data path's
// order, written once here, checked over every source file of host/.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

// The stages, lowest first: a file of one may include its own stage and the
// ones before it. `base` are headers every stage may include: the traversal
// layout and the kernels' shared code, and the public headers that only
// declare types (errors, plain types, G-buffer channels and the parse of
// their names, the version).
const std::vector<std::string> kStages = {"base",    "util",   "scene",  "bvh",      "fold", "reference", "rays",
                                          "resolve", "opencl", "output", "pipeline", "api",  "python"};
const std::vector<std::string> kBasePublicHeaders = {"rayfold/errors.h", "rayfold/types.h", "rayfold/gbuffer.h",
                                                     "rayfold/version.h"};

int rank_of(const std::string& stage) {
  const auto it = std::find(kStages.begin(), kStages.end(), stage);
  return it == kStages.end() ? -1 : static_cast<int>(it - kStages.begin());
}

// The stage of a file under host/ (its first folder; the public headers in
// include/ are the API's).
std::string stage_of_file(const fs::path& relative) {
  const std::string first = relative.begin()->string();
  if (relative.has_parent_path()) return first == "include" ? "api" : first;
  return "base";  // device_layout.h beside the stages
}

// The stage of an included header, as the including file (stage `from`)
// names it: a folder-qualified name is that folder's, a bare one the
// includer's own folder's or a top-level header (base).
std::string stage_of_include(const std::string& name, const std::string& from, const fs::path& host) {
  if (std::find(kBasePublicHeaders.begin(), kBasePublicHeaders.end(), name) != kBasePublicHeaders.end())
    return "base";
  const size_t slash = name.find('/');
  if (slash == std::string::npos) return fs::exists(host / name) || name.rfind("rf_", 0) == 0 ? "base" : from;
  const std::string folder = name.substr(0, slash);
  if (folder == "rayfold") return "api";
  return rank_of(folder) >= 0 ? folder : from;  // another library's header
}

TEST(Layering, NoStageIncludesAStageAboveIt) {
  const fs::path host = fs::path(RAYFOLD_SOURCE_DIR) / "host";
  const std::regex include_line(R"(^\s*#\s*include\s*"([^"]+)\")");
  size_t files = 0, includes = 0;
  std::vector<std::string> violations;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(host)) {
    const std::string ext = e.path().extension().string();
    if (!e.is_regular_file() || (ext != ".h" && ext != ".cpp" && ext != ".in")) continue;
    const fs::path relative = fs::relative(e.path(), host);
    const std::string stage = stage_of_file(relative);
    ASSERT_GE(rank_of(stage), 0) << relative << " is in a folder the order does not name (" << stage
                                 << "): add it to kStages";
    ++files;
    std::ifstream in(e.path());
    std::string line;
    for (int n = 1; std::getline(in, line); ++n) {
      std::smatch m;
      if (!std::regex_search(line, m, include_line)) continue;
      ++includes;
      const std::string target = stage_of_include(m[1], stage, host);
      if (rank_of(target) > rank_of(stage))
        violations.push_back(relative.string() + ":" + std::to_string(n) + " (" + stage + ") includes \"" +
                             m[1].str() + "\" (" + target + ")");
    }
  }
  // The premise: the walk saw the library.
  EXPECT_GT(files, 100u);
  EXPECT_GT(includes, 200u);
  std::string all;
  for (const std::string& v : violations) all += "\n  " + v;
  EXPECT_TRUE(violations.empty()) << violations.size() << " includes of a stage above the includer's:" << all;
}

// What the CLI's render, info and devices code may include besides the
// standard library: the public API, the CLI's own files, the utilities
// every stage may use, and the fixtures shared with the benchmarks. It is
// built on the API (a channel or option written once for the CLI, C++ and
// Python); `rayfold bench` times the core's stages and is the exception.
// Checked on the CLI's own files: the fixtures it uses (the synthetic
// --animate motion) are shared with the benchmarks and may use the core.
bool cli_may_include(const std::string& name) {
  for (const char* prefix : {"rayfold/", "cli/", "util/", "fixtures/"})
    if (name.rfind(prefix, 0) == 0) return true;
  return name.find('/') == std::string::npos && name.find('.') == std::string::npos;  // <map>-style names
}

TEST(Layering, TheCliIsBuiltOnThePublicApi) {
  const fs::path cli = fs::path(RAYFOLD_SOURCE_DIR) / "tools" / "cli";
  const std::regex include_line(R"(^\s*#\s*include\s*"([^"]+)\")");
  size_t files = 0;
  std::vector<std::string> violations;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(cli)) {
    const std::string name = e.path().filename().string();
    if (!e.is_regular_file() || name.rfind("bench_command", 0) == 0) continue;
    ++files;
    std::ifstream in(e.path());
    std::string line;
    for (int n = 1; std::getline(in, line); ++n) {
      std::smatch m;
      if (std::regex_search(line, m, include_line) && !cli_may_include(m[1]))
        violations.push_back(fs::relative(e.path(), cli).string() + ":" + std::to_string(n) + " includes \"" +
                             m[1].str() + "\"");
    }
  }
  EXPECT_GT(files, 10u);
  std::string all;
  for (const std::string& v : violations) all += "\n  " + v;
  EXPECT_TRUE(violations.empty()) << violations.size() << " includes of the library's insides:" << all;
  EXPECT_FALSE(cli_may_include("scene/animation.h"));  // the check can fail
}

// The check can fail: a file that reached up would be named.
TEST(Layering, AnIncludeFromAboveIsNamed) {
  const fs::path host = fs::path(RAYFOLD_SOURCE_DIR) / "host";
  EXPECT_EQ(stage_of_include("pipeline/pipeline.h", "util", host), "pipeline");
  EXPECT_GT(rank_of(stage_of_include("pipeline/pipeline.h", "util", host)), rank_of("util"));
  EXPECT_EQ(stage_of_include("rayfold/renderer.h", "scene", host), "api");
  EXPECT_EQ(stage_of_include("rayfold/errors.h", "util", host), "base");
  EXPECT_EQ(stage_of_include("device_layout.h", "bvh", host), "base");
  EXPECT_EQ(stage_of_include("rf_trace.h", "bvh", host), "base");
  EXPECT_EQ(stage_of_include("plane_pool.h", "python", host), "python");
  EXPECT_EQ(stage_of_include("glm/vec3.hpp", "scene", host), "scene");
  EXPECT_EQ(stage_of_file(fs::path("include") / "rayfold" / "renderer.h"), "api");
  EXPECT_EQ(stage_of_file(fs::path("scene") / "gltf" / "document.cpp"), "scene");
}

}  // namespace
