#include "util/atomic_file.h"

#include <fstream>
#include <iterator>

#include <dirent.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <set>
#include <vector>

#include "util/errors.h"
#include "util/output_transaction.h"

namespace rayfold::core {
namespace {

constexpr const char* kTag = ".rayfold-";

std::pair<std::string, std::string> split_path(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return {"", path};
  return {path.substr(0, slash + 1), path.substr(slash + 1)};
}

std::string errno_text() { return std::strerror(errno); }

// True when `digits` names a process that no longer exists.
bool process_ended(const std::string& digits) {
  if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 9) return false;
  const long pid = std::strtol(digits.c_str(), nullptr, 10);
  if (pid <= 0 || pid == ::getpid()) return false;
  if (::kill(static_cast<pid_t>(pid), 0) != 0) return errno == ESRCH;
  // A zombie has ended too: where no one reaps orphans (a container's
  // init), a writer killed with its parent stays one, and its temporaries
  // stayed with it.
  std::ifstream stat("/proc/" + digits + "/stat");
  std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
  const size_t paren = text.rfind(')');
  return paren != std::string::npos && paren + 2 < text.size() && text[paren + 2] == 'Z';
}

// The pid in ".<name>.rayfold-<pid>-<n>.tmp", or "" when the name is not one.
std::string temporary_pid(const std::string& name) {
  if (name.size() < 5 || name[0] != '.' || name.compare(name.size() - 4, 4, ".tmp") != 0) return "";
  const size_t tag = name.rfind(kTag);
  if (tag == std::string::npos) return "";
  const size_t start = tag + std::strlen(kTag), dash = name.find('-', start);
  if (dash == std::string::npos) return "";
  const std::string counter = name.substr(dash + 1, name.size() - 4 - dash - 1);
  if (counter.empty() || counter.find_first_not_of("0123456789") != std::string::npos) return "";
  return name.substr(start, dash - start);
}

}  // namespace

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)) {
  static std::atomic<unsigned> counter{0};
  const auto [folder, name] = split_path(path_);
  temp_ = folder + "." + name + kTag + std::to_string(::getpid()) + "-" + std::to_string(counter++) + ".tmp";
  entry_ = register_temporary(temp_);
}

AtomicFile::~AtomicFile() {
  if (committed_) return;
  std::remove(temp_.c_str());
  release_temporary(entry_);
}

void AtomicFile::commit() {
  if (OutputTransaction::adopt(temp_, path_, entry_)) {
    committed_ = true;
    return;
  }
  commit_now();
}

void AtomicFile::commit_now() {
  if (std::rename(temp_.c_str(), path_.c_str()) != 0)
    throw RuntimeFailure(path_ + ": cannot move the finished file into place: " + errno_text());
  release_temporary(entry_);
  committed_ = true;
}

void write_temp_bytes(const AtomicFile& file, const void* data, size_t size) {
  std::FILE* f = std::fopen(file.temp_path().c_str(), "wb");
  if (!f) throw RuntimeFailure(file.path() + ": cannot write the file: " + errno_text());
  const bool wrote = std::fwrite(data, 1, size, f) == size && std::fflush(f) == 0;
  const int write_errno = errno;
  const bool closed = std::fclose(f) == 0;
  if (!wrote || !closed)
    throw RuntimeFailure(file.path() + ": cannot write the file: " + std::strerror(wrote ? errno : write_errno));
}

void write_text_file(const std::string& path, const std::string& text) {
  AtomicFile file(path);
  write_temp_bytes(file, text.data(), text.size());
  file.commit();
}

void check_writable(const std::string& path) {
  if (path.empty()) throw InputError(path, "empty output path");
  AtomicFile probe(path);
  std::FILE* f = std::fopen(probe.temp_path().c_str(), "wb");
  if (!f) throw InputError(path, std::string("cannot write here: ") + errno_text());
  std::fclose(f);
  static std::mutex mutex;
  static std::set<std::string> scanned;
  const std::string folder = split_path(path).first;
  const std::lock_guard<std::mutex> lock(mutex);
  if (scanned.insert(folder).second) remove_stale_temporaries(folder.empty() ? "." : folder, path);
}

void make_output_folders(const std::string& path) {
  // Each missing level, deepest first ("a/b/" -> "a/b", "a"); made from the
  // top down, so that a failed run can remove them deepest first.
  auto parent = [](std::string f) {
    while (!f.empty() && f.back() == '/') f.pop_back();
    const size_t slash = f.find_last_of('/');
    return slash == std::string::npos ? std::string() : f.substr(0, slash);
  };
  std::vector<std::string> missing;
  for (std::string f = parent(path); !f.empty() && ::access(f.c_str(), F_OK) != 0; f = parent(f)) missing.push_back(f);
  for (auto f = missing.rbegin(); f != missing.rend(); ++f) {
    if (::mkdir(f->c_str(), 0777) != 0 && errno != EEXIST)
      throw InputError(path, "cannot make its folder " + *f + ": " + errno_text());
    OutputTransaction::adopt_folder(*f);
  }
}

size_t remove_stale_temporaries(const std::string& folder, const std::string& target) {
  DIR* dir = ::opendir(folder.c_str());
  if (!dir) return 0;
  const std::string legacy = target.empty() ? "" : split_path(target).second + ".tmp-";
  std::string prefix = folder;
  if (!prefix.empty() && prefix.back() != '/') prefix += '/';
  size_t removed = 0;
  while (const dirent* d = ::readdir(dir)) {
    const std::string name = d->d_name;
    std::string pid = temporary_pid(name);
    if (pid.empty() && !legacy.empty() && name.compare(0, legacy.size(), legacy) == 0) pid = name.substr(legacy.size());
    if (process_ended(pid) && ::unlink((prefix + name).c_str()) == 0) ++removed;
  }
  ::closedir(dir);
  return removed;
}

}  // namespace rayfold::core
