// What the rayfold command's subcommands share: the bundled scene, the
// options of the tracer, the output checks, and each subcommand's entry.
#pragma once

#include <cstddef>
#include <initializer_list>
#include <string>
#include <vector>

#include "cli/cli_args.h"
#include "rayfold/renderer.h"

namespace rayfold::core::commands {

// The bundled scene: in the source tree for a build, beside the binary
// (../share/rayfold) once installed.
std::string default_scene();

// 1234567 -> "1,234,567".
std::string with_commas(size_t n);

// Appends the lines of `more` that `said` does not hold yet, in order: a
// run's warnings, each once.
void append_unsaid(std::vector<std::string>& said, const std::vector<std::string>& more);

// Options render and bench share: which tracer, which device, how the work
// is arranged (--braid, --no-merge, --no-cull). Returns false when `a` is
// none of them.
bool parse_renderer_option(const std::string& a, cli::Args& args, rayfold::RendererOptions& r);

// After parsing: options that contradict each other (UsageError).
void check_renderer_options(const rayfold::RendererOptions& r);

struct Output {
  const char* option;
  const std::string* path;
  const char* extension;
};

// The extension decides the format: a mismatch is a UsageError, not a file
// of one kind under another's name.
void check_outputs(std::initializer_list<Output> outputs);

// Before any expensive work: the output's missing folders made (mkdir -p;
// removed again if the run fails) and a file created there as a test
// (check_writable); InputError naming the path otherwise.
void prepare_output(const std::string& path);

// The subcommands, each given the arguments after its name; the exit code.
int run_render(cli::Args& args);
int run_info(cli::Args& args);
int run_bench_command(cli::Args& args);

}  // namespace rayfold::core::commands
