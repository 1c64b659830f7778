// rayfold: the command-line tool. `rayfold render` traces primary rays and
// writes the hit info (tools/cli/commands/render_command.cpp), `rayfold info`
// describes a scene, `rayfold bench` measures the fold modes; here the
// commands are told apart.
#include <cstdio>
#include <string>

#include "cli/cli_args.h"
#include "cli/commands/common.h"
#include "util/errors.h"

#ifndef RAYFOLD_VERSION
#define RAYFOLD_VERSION "unknown"
#endif

namespace rayfold::core {
namespace {

using commands::run_bench_command;
using commands::run_info;
using commands::run_render;

const char* kUsage =
    "usage: rayfold <command> [options]\n"
    "\n"
    "commands:\n"
    "  render [SCENE]   trace primary rays and write the hit info\n"
    "  info SCENE       meshes, instances, triangles and bounds of a scene\n"
    "  bench [SCENE]    every fold mode on the same camera path: the paper's tables\n"
    "  devices          the OpenCL platforms and devices (--device picks by name)\n"
    "  --version        rayfold's version\n"
    "\n"
    "`rayfold <command> --help` describes a command. SCENE is a .gltf or .glb file;\n"
    "without it, render uses the bundled default scene.\n"
    "exit codes: 0 success, 2 bad input or usage, 3 runtime failure\n";

const char* kDevicesUsage =
    "usage: rayfold devices\n"
    "Lists the OpenCL platforms and devices this machine offers, with their compute units;\n"
    "--device NAME (render, bench) picks the first whose platform or name contains NAME; cpu or gpu, the first of\n"
    "that type.\n";

int run(int argc, char** argv) {
  if (argc < 2) {
    std::fputs(kUsage, stderr);
    return 2;
  }
  const std::string command = argv[1];
  cli::Args args(argc, argv, 2);
  if (command == "--help" || command == "-h" || command == "help") {
    std::fputs(kUsage, stdout);
    return 0;
  }
  if (command == "--version" || command == "version") {
    std::printf("rayfold %s\n", RAYFOLD_VERSION);
    return 0;
  }
  if (command == "devices") {
    if (!args.done() && (args.peek() == "--help" || args.peek() == "-h")) {
      std::fputs(kDevicesUsage, stdout);
      return 0;
    }
    if (!args.done()) throw UsageError("devices: takes no arguments");
    std::printf("OpenCL devices (--device NAME picks the first whose platform or name contains NAME):\n%s",
                rayfold::opencl_devices().c_str());
    return 0;
  }
  if (command == "render") return run_render(args);
  if (command == "info") return run_info(args);
  if (command == "bench") return run_bench_command(args);
  throw UsageError("unknown command '" + command + "' (see rayfold --help)");
}

}  // namespace
}  // namespace rayfold::core

int main(int argc, char** argv) {
  // Line by line also into pipes and logs, as on a terminal.
  std::setvbuf(stdout, nullptr, _IOLBF, 0);
  return rayfold::core::cli::guarded_main([&] { return rayfold::core::run(argc, argv); });
}