// Compiled programs kept between processes. A program built from source
// costs PoCL 70 to 120 ms even with its own cache warm (it preprocesses the
// source to find its entry); from the binary it gave before, 12 to 20 ms.
// That is a fifth to a third of the time to a first G-buffer on a small
// scene, paid by every new process: a CLI run, a Python session, each Ray
// worker. The binary is the driver's own output for the same source,
// options, device and driver, so it traces the same bits.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace rayfold::core {

// The folder: $RAYFOLD_KERNEL_CACHE when set ("", "off", "0" or "none", in
// any case: no cache; a relative path is taken from the current folder when
// first read), else $XDG_CACHE_HOME/rayfold/kernels when that is an
// absolute path, else $HOME/.cache/rayfold/kernels; "" for no cache.
std::string kernel_cache_dir();

// The binary stored in `dir` for exactly this key (the device's and
// driver's names and versions, the build options and the source); empty
// when there is none or when the file is not whole (cut short, damaged,
// another key's). Never throws.
std::vector<unsigned char> load_cached_program(const std::string& dir, const std::string& key) noexcept;

// Stores the binary for `key`, creating `dir` (owner-only: a binary is
// native code the process will run) as needed. Written under a temporary
// name and renamed into place, so that readers never see part of one; the
// folder keeps its newest kMaxCachedPrograms. A cache that cannot be
// written (read-only, full) is not an error: false, and nothing is left
// behind. Never throws.
bool store_cached_program(const std::string& dir, const std::string& key,
                          const std::vector<unsigned char>& binary) noexcept;
constexpr size_t kMaxCachedPrograms = 32;

// Programs this process took from a cache so far (ClDevice::build counts).
size_t kernel_cache_hits();
void count_kernel_cache_hit();

}  // namespace rayfold::core
