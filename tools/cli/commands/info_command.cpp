// `rayfold info`: what a scene holds, and the ids its renders use.
#include <cstdio>

#include "cli/commands/common.h"
#include "scene/gltf_loader.h"
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
  std::vector<std::string> warnings;
  const Scene scene = load_gltf(path, &warnings);
  for (const std::string& w : warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
  const Aabb b = scene.world_bounds();
  std::printf("%s\n", path.c_str());
  std::printf("  meshes      %s\n", with_commas(scene.meshes.size()).c_str());
  std::printf("  instances   %s\n", with_commas(scene.instances.size()).c_str());
  std::printf("  triangles   %s rendered, %s stored\n", with_commas(scene.triangle_count()).c_str(),
              with_commas(scene.unique_triangle_count()).c_str());
  if (b.empty())
    std::printf("  bounds      (empty)\n");
  else
    std::printf("  bounds      (%g, %g, %g) .. (%g, %g, %g)\n", b.lo.x, b.lo.y, b.lo.z, b.hi.x, b.hi.y, b.hi.z);
  for (size_t i = 0; i < scene.scene_names.size(); ++i)
    std::printf("  scene %-5zu %s%s\n", i, scene.scene_names[i].empty() ? "(unnamed)" : scene.scene_names[i].c_str(),
                static_cast<int>(i) == scene.scene_index ? "  [shown; --scene N picks another]" : "");
  for (size_t i = 0; i < scene.cameras.size(); ++i) {
    const Scene::FileCamera& c = scene.cameras[i];
    if (c.perspective)
      std::printf("  camera %-4zu node %d '%s': eye (%g, %g, %g), looking at (%g, %g, %g), vfov %g\n", i, c.node,
                  c.name.c_str(), c.spec.eye.x, c.spec.eye.y, c.spec.eye.z, c.spec.look_at.x, c.spec.look_at.y,
                  c.spec.look_at.z, c.spec.vfov_degrees);
    else
      std::printf("  camera %-4zu node %d '%s': eye (%g, %g, %g), looking at (%g, %g, %g), orthographic, ymag %g\n", i,
                  c.node, c.name.c_str(), c.spec.eye.x, c.spec.eye.y, c.spec.eye.z, c.spec.look_at.x, c.spec.look_at.y,
                  c.spec.look_at.z, c.spec.ymag);
  }
  // The ids the G-buffer's InstanceID channel holds (render --ids writes them as JSON).
  std::printf("  instance ids (InstanceID, mesh, node name):\n");
  for (size_t i = 0; i < scene.instances.size(); ++i)
    std::printf("    %-6zu mesh %-5u %s\n", i, scene.instances[i].mesh, scene.instances[i].name.c_str());
  return 0;
}

}  // namespace rayfold::core::commands
