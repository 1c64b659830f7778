#include "opencl/kernel_cache.h"

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <set>

#include "util/atomic_file.h"
#include "util/checksum.h"

namespace rayfold::core {
namespace fs = std::filesystem;
namespace {

// A cached program's file:
//   bytes  0..15  kMagic
//   bytes 16..23  the key's length k
//   bytes 24..31  the binary's length b
//   bytes 32..39  fnv1a of the binary
//   bytes 40..    the key itself (compared whole: no hash decides), then the
//                 binary; the file is exactly 40 + k + b bytes
constexpr char kMagic[16] = "rayfold-kernel\n";
constexpr size_t kHeader = 16 + 8 + 8 + 8;
constexpr uint64_t kMaxBinary = uint64_t{1} << 32;

std::atomic<size_t> hits{0};

std::string file_for(const std::string& dir, const std::string& key) {
  char name[32];
  std::snprintf(name, sizeof name, "%016llx.bin", static_cast<unsigned long long>(fnv1a(key.data(), key.size())));
  return dir + "/" + name;
}

bool means_off(std::string v) {
  for (char& c : v) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return v.empty() || v == "off" || v == "0" || v == "none";
}

// The newest kMaxCachedPrograms files kept: every change of the source, the
// options or the driver adds one, and nothing else would remove the old.
void prune(const std::string& dir) {
  std::error_code ec;
  std::vector<std::pair<fs::file_time_type, fs::path>> files;
  for (const fs::directory_entry& e : fs::directory_iterator(dir, ec))
    if (e.path().extension() == ".bin") files.emplace_back(e.last_write_time(ec), e.path());
  if (ec || files.size() <= kMaxCachedPrograms) return;
  std::sort(files.begin(), files.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  for (size_t i = kMaxCachedPrograms; i < files.size(); ++i) fs::remove(files[i].second, ec);
}

}  // namespace

std::string kernel_cache_dir() {
  if (const char* env = std::getenv("RAYFOLD_KERNEL_CACHE")) {
    if (means_off(env)) return "";
    std::error_code ec;
    const fs::path p = fs::absolute(env, ec);
    return ec ? "" : p.string();
  }
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && xdg[0] == '/')
    return std::string(xdg) + "/rayfold/kernels";
  if (const char* home = std::getenv("HOME"); home && home[0] == '/')
    return std::string(home) + "/.cache/rayfold/kernels";
  return "";
}

std::vector<unsigned char> load_cached_program(const std::string& dir, const std::string& key) noexcept {
  try {
    const std::string path = file_for(dir, key);
    std::error_code ec;
    const uintmax_t size = fs::file_size(path, ec);
    if (ec || size < kHeader) return {};
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) return {};
    std::vector<unsigned char> binary;
    char head[kHeader];
    uint64_t key_length = 0, length = 0, sum = 0;
    bool ok = std::fread(head, 1, kHeader, f) == kHeader && std::memcmp(head, kMagic, 16) == 0;
    if (ok) {
      std::memcpy(&key_length, head + 16, 8);
      std::memcpy(&length, head + 24, 8);
      std::memcpy(&sum, head + 32, 8);
      // The lengths checked against the file before anything is allocated.
      ok = key_length == key.size() && length > 0 && length < kMaxBinary && size == kHeader + key_length + length;
    }
    if (ok) {
      std::string stored(key_length, '\0');
      ok = std::fread(stored.data(), 1, key_length, f) == key_length && stored == key;
    }
    if (ok) {
      binary.resize(length);
      ok = std::fread(binary.data(), 1, length, f) == length &&
           fnv1a(reinterpret_cast<const char*>(binary.data()), length) == sum;
    }
    std::fclose(f);
    if (!ok) binary.clear();
    return binary;
  } catch (...) {  // memory for a file the header says is whole: not cached
    return {};
  }
}

bool store_cached_program(const std::string& dir, const std::string& key,
                          const std::vector<unsigned char>& binary) noexcept {
  if (binary.empty() || binary.size() >= kMaxBinary) return false;
  try {
    std::error_code ec;
    if (!fs::is_directory(dir, ec)) {
      fs::create_directories(dir, ec);
      if (ec) return false;
      fs::permissions(dir, fs::perms::owner_all, fs::perm_options::replace, ec);
    }
    // Temporaries of processes killed mid-write, once a process and folder.
    {
      static std::mutex mutex;
      static std::set<std::string> swept;
      const std::lock_guard<std::mutex> lock(mutex);
      if (swept.insert(dir).second) remove_stale_temporaries(dir);
    }
    std::vector<char> out(kHeader + key.size() + binary.size());
    const uint64_t key_length = key.size(), length = binary.size();
    const uint64_t sum = fnv1a(reinterpret_cast<const char*>(binary.data()), binary.size());
    std::memcpy(out.data(), kMagic, 16);
    std::memcpy(out.data() + 16, &key_length, 8);
    std::memcpy(out.data() + 24, &length, 8);
    std::memcpy(out.data() + 32, &sum, 8);
    std::memcpy(out.data() + kHeader, key.data(), key.size());
    std::memcpy(out.data() + kHeader + key.size(), binary.data(), binary.size());
    {
      AtomicFile file(file_for(dir, key));
      write_temp_bytes(file, out.data(), out.size());
      file.commit_now();
    }  // a failure above: the temporary removed with `file`
    prune(dir);
    return true;
  } catch (...) {
    return false;
  }
}

size_t kernel_cache_hits() { return hits.load(); }
void count_kernel_cache_hit() { ++hits; }

}  // namespace rayfold::core
