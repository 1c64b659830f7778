// rayfold-gen-scene: writes a generated atrium scene as .glb. The bundled
// default scene is this tool's output with its default options.
#include <cstdio>
#include <string>

#include "cli_args.h"
#include "gltf_writer.h"
#include "scene_gen.h"
#include "util/errors.h"

int main(int argc, char** argv) {
  using namespace rayfold;
  using namespace rayfold::core;
  return cli::guarded_main([&] {
    GenOptions opt;
    std::string out;
    cli::Args args(argc, argv, 1);
    while (!args.done()) {
      const std::string a = args.next();
      if (a == "--help" || a == "-h") {
        std::puts(
            "usage: rayfold-gen-scene -o OUT.glb [--seed N] [--objects N] [--triangles N]\n"
            "writes the deterministic atrium scene (defaults: seed 1, 240 objects, 150000 triangles)");
        return 0;
      } else if (a == "--seed") {
        opt.seed = static_cast<uint64_t>(cli::parse_int(a, args.value(a), 0, 2147483647));
      } else if (a == "--objects") {
        opt.objects = cli::parse_int(a, args.value(a), 1, 1000000);
      } else if (a == "--triangles") {
        opt.triangle_budget = static_cast<size_t>(cli::parse_int(a, args.value(a), 1, 2147483647));
      } else if (a == "-o" || a == "--output") {
        out = args.value(a);
      } else {
        throw UsageError("unknown argument '" + a + "'");
      }
    }
    if (out.empty()) throw UsageError("no output file (-o OUT.glb)");
    const Scene scene = generate_atrium(opt);
    write_glb(scene, out);
    std::printf("%s: %zu instances, %zu meshes, %zu triangles\n", out.c_str(), scene.instances.size(),
                scene.meshes.size(), scene.triangle_count());
    return 0;
  });
}
