// `rayfold info`: what a scene holds, and the ids its renders use.
#include <array>
#include <cstdio>

#include "cli/commands/common.h"
#include "rayfold/scene.h"
#include "util/errors.h"

namespace rayfold::core::commands {
namespace {

const char* kInfoUsage =
    "usage: rayfold info SCENE\n\nprints meshes, instances, triangles, bounds, the file's scenes and cameras, and\n"
    "every instance id with its mesh and node name\n";

}  // namespace

int run_info(cli::Args& args) {
  std::string path;
  while (!args.done()) {
    const std::string a = args.next();
    if (a == "--help" || a == "-h") {
      std::fputs(kInfoUsage, stdout);
      return 0;
    }
    if (!a.empty() && a[0] == '-') throw UsageError("info: unknown option '" + a + "'");
    if (!path.empty()) throw UsageError("info: more than one scene given");
    path = a;
  }
  if (path.empty()) throw UsageError("info: no scene given (usage: rayfold info SCENE)");
  const rayfold::Scene scene = rayfold::Scene::load(path);
  for (const std::string& w : scene.warnings()) std::fprintf(stderr, "warning: %s\n", w.c_str());
  const std::array<double, 6> b = scene.bounds();
  std::printf("%s\n", path.c_str());
  std::printf("  meshes      %s\n", with_commas(scene.mesh_count()).c_str());
  std::printf("  instances   %s\n", with_commas(scene.instance_count()).c_str());
  std::printf("  triangles   %s rendered, %s stored\n", with_commas(scene.triangle_count()).c_str(),
              with_commas(scene.stored_triangle_count()).c_str());
  if (scene.triangle_count() == 0)
    std::printf("  bounds      (empty)\n");
  else
    std::printf("  bounds      (%g, %g, %g) .. (%g, %g, %g)\n", b[0], b[1], b[2], b[3], b[4], b[5]);
  const std::vector<std::string> scene_names = scene.scene_names();
  for (size_t i = 0; i < scene_names.size(); ++i)
    std::printf("  scene %-5zu %s%s\n", i, scene_names[i].empty() ? "(unnamed)" : scene_names[i].c_str(),
                static_cast<int>(i) == scene.scene_index() ? "  [shown; --scene N picks another]" : "");
  const std::vector<rayfold::Scene::FileCamera> cameras = scene.file_cameras();
  for (size_t i = 0; i < cameras.size(); ++i) {
    const rayfold::Scene::FileCamera& c = cameras[i];
    const rayfold::View& v = c.view;
    if (!v.orthographic)
      std::printf("  camera %-4zu node %d '%s': eye (%g, %g, %g), looking at (%g, %g, %g), vfov %g\n", i, c.node,
                  c.name.c_str(), v.eye[0], v.eye[1], v.eye[2], v.target[0], v.target[1], v.target[2], v.vfov_degrees);
    else
      std::printf("  camera %-4zu node %d '%s': eye (%g, %g, %g), looking at (%g, %g, %g), orthographic, ymag %g\n", i,
                  c.node, c.name.c_str(), v.eye[0], v.eye[1], v.eye[2], v.target[0], v.target[1], v.target[2],
                  v.half_height);
  }
  // The ids the G-buffer's InstanceID channel holds (render --ids writes them as JSON).
  std::printf("  instance ids (InstanceID, mesh, node name):\n");
  const std::vector<std::string> names = scene.instance_names();
  for (uint32_t i = 0; i < scene.instance_count(); ++i)
    std::printf("    %-6u mesh %-5u %s\n", i, scene.instance_mesh(i), names[i].c_str());
  return 0;
}

}  // namespace rayfold::core::commands
