#include "cli/commands/common.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>

#include "util/atomic_file.h"
#include "util/errors.h"

#ifndef RAYFOLD_DEFAULT_SCENE
#define RAYFOLD_DEFAULT_SCENE "scenes/atrium.glb"
#endif

namespace rayfold::core::commands {
std::string default_scene() {
  std::error_code ec;
  if (std::filesystem::exists(RAYFOLD_DEFAULT_SCENE, ec)) return RAYFOLD_DEFAULT_SCENE;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const std::filesystem::path installed = exe.parent_path().parent_path() / "share" / "rayfold" / "atrium.glb";
    if (std::filesystem::exists(installed, ec)) return installed.string();
  }
  return RAYFOLD_DEFAULT_SCENE;
}

void append_unsaid(std::vector<std::string>& said, const std::vector<std::string>& more) {
  for (const std::string& w : more)
    if (std::find(said.begin(), said.end(), w) == said.end()) said.push_back(w);
}

std::string with_commas(size_t n) {
  std::string s = std::to_string(n);
  for (int i = static_cast<int>(s.size()) - 3; i > 0; i -= 3) s.insert(static_cast<size_t>(i), ",");
  return s;
}

// Options render and bench share: which tracer, which device, how built.
// Returns false when `a` is none of them.
bool parse_renderer_option(const std::string& a, cli::Args& args, rayfold::RendererOptions& r) {
  if (a == "--backend") {
    const std::string b = args.value(a);
    if (b == "opencl")
      r.backend = Backend::opencl;
    else if (b == "cpu")
      r.backend = Backend::cpu;
    else
      throw UsageError("--backend: '" + b + "' is not opencl or cpu");
  } else if (a == "--kernel") {
    const std::string k = args.value(a);
    if (k == "tile")
      r.kernel = Kernel::tile;
    else if (k == "single")
      r.kernel = Kernel::single;
    else if (k == "auto")
      r.kernel = Kernel::automatic;
    else if (k == "measure")
      r.kernel = Kernel::measure;
    else
      throw UsageError("--kernel: '" + k + "' is not tile, single, measure or auto");
  } else if (a == "--device") {
    r.device = args.value(a);
  } else if (a == "--fast") {
    r.fast_math = true;
  } else if (a == "--threads") {
    r.threads = static_cast<unsigned>(cli::parse_int(a, args.value(a), 0, 1024));
  } else if (a == "--braid") {
    r.braid = cli::parse_int(a, args.value(a), 0, 1024);
  } else if (a == "--no-merge") {
    r.merge_static = false;
  } else if (a == "--no-cull") {
    r.cull = false;
  } else {
    return false;
  }
  return true;
}

// After parsing: options that contradict each other.
void check_renderer_options(const rayfold::RendererOptions& r) {
  if (r.backend == Backend::cpu && r.kernel != Kernel::automatic)
    throw UsageError("--kernel: the CPU backend runs the reference tracer, not an OpenCL kernel");
  if (r.backend == Backend::cpu && !r.device.empty())
    throw UsageError("--device: the CPU backend runs the reference tracer on no OpenCL device");
}

// The extension decides the format: a mismatch is an error, not a file of
// one kind under another's name. Kinds have different extensions, so no two
// outputs can name one file either.
void check_outputs(std::initializer_list<Output> outputs) {
  namespace fs = std::filesystem;
  for (const Output& o : outputs) {
    if (o.path->empty()) continue;
    std::string ext = fs::path(*o.path).extension().string();
    for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    if (ext != o.extension)
      throw UsageError(std::string(o.option) + ": '" + *o.path + "' must end in " + o.extension +
                       " (-o writes OpenEXR, --png a PNG preview, --stats JSON)");
  }
}

void prepare_output(const std::string& path) {
  make_output_folders(path);
  check_writable(path);
}

}  // namespace rayfold::core::commands
