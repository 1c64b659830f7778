// libFuzzer target: arbitrary bytes as a glTF file (.gltf or .glb), through
// the loader, the bottom- and top-level builds and a tiny trace on the CPU
// reference, folded and unfolded. Bad input must end in InputError (or
// UsageError for an unusable camera), never a crash or a sanitizer report;
// a folded image that differs from the unfolded one aborts: that is a bug too.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "../../host/errors.h"
#include "../../host/gltf_loader.h"
#include "../../host/renderer.h"

namespace {

const std::string& scratch_path() {
  static const std::string path = "/tmp/rayfold_fuzz_" + std::to_string(::getpid()) + ".gltf";
  return path;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace rayfold;
  {
    std::FILE* f = std::fopen(scratch_path().c_str(), "wb");
    if (!f) return 0;
    std::fwrite(data, 1, size, f);
    std::fclose(f);
  }
  try {
    const Scene scene = load_gltf(scratch_path());
    if (scene.triangle_count() > 100000) return 0;  // keep each input fast
    RendererOptions options;
    options.backend = Backend::cpu;
    options.threads = 1;
    Renderer renderer(scene, options);
    const CameraSpec spec = scene.camera ? *scene.camera : frame_bounds(scene.world_bounds());
    const Camera camera = make_camera(spec, 9, 7);
    const RenderResult none = renderer.render(camera, 1, FrameOptions{FoldMode::none});
    const RenderResult xy = renderer.render(camera, 1, FrameOptions{FoldMode::xy});
    if (std::memcmp(none.hits.data(), xy.hits.data(), none.hits.size() * sizeof(rf_pixel_hit)) != 0) {
      std::fprintf(stderr, "fuzz: folded render differs from unfolded\n");
      std::abort();
    }
  } catch (const InputError&) {
  } catch (const UsageError&) {
  }
  return 0;
}
