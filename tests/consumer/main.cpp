// Renders a glTF file through the installed API, folded and not, on the CPU
// reference and on OpenCL, and checks that all four agree bit for bit and
// that something was hit. Usage: consumer SCENE.glb
#include <cstdio>
#include <cstring>

#include <rayfold/rayfold.h>

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: consumer SCENE.glb\n");
    return 2;
  }
  try {
    const rayfold::Scene scene = rayfold::Scene::load(argv[1]);
    const rayfold::Camera camera = scene.default_camera(160, 90);
    rayfold::GBuffer reference;
    for (rayfold::Backend backend : {rayfold::Backend::cpu, rayfold::Backend::opencl}) {
      rayfold::RendererOptions options;
      options.backend = backend;
      rayfold::Renderer renderer(scene, options);
      for (rayfold::Fold fold : {rayfold::Fold::none, rayfold::Fold::xy}) {
        const rayfold::GBuffer g = renderer.render(camera, fold);
        if (reference.depth.empty()) {
          reference = g;
          continue;
        }
        if (std::memcmp(g.depth.data(), reference.depth.data(), g.depth.size() * sizeof(float)) != 0 ||
            g.instance_id != reference.instance_id || g.primitive_id != reference.primitive_id) {
          std::fprintf(stderr, "consumer: %s differs from the CPU reference\n", renderer.device_name().c_str());
          return 1;
        }
      }
    }
    std::printf("rayfold %s: %zu instances, %zu of %zu pixels hit\n", RAYFOLD_VERSION_STRING, scene.instance_count(),
                reference.hits, reference.depth.size());
    return reference.hits > 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "consumer: %s\n", e.what());
    return 1;
  }
}
