#include "util/atomic_file.h"

#include <unistd.h>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "util/errors.h"

namespace rayfold::core {

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)) {
  temp_ = path_ + ".tmp-" + std::to_string(::getpid());
}

AtomicFile::~AtomicFile() {
  if (!committed_) std::remove(temp_.c_str());
}

void AtomicFile::commit() {
  if (std::rename(temp_.c_str(), path_.c_str()) != 0)
    throw InputError(path_, std::string("cannot move the finished file into place: ") + std::strerror(errno));
  committed_ = true;
}

void write_text_file(const std::string& path, const std::string& text) {
  AtomicFile file(path);
  {
    std::ofstream out(file.temp_path());
    out << text;
    if (!out) throw InputError(path, "cannot write the file");
  }
  file.commit();
}

void check_writable(const std::string& path) {
  if (path.empty()) throw InputError(path, "empty output path");
  AtomicFile probe(path);
  std::FILE* f = std::fopen(probe.temp_path().c_str(), "wb");
  if (!f) throw InputError(path, std::string("cannot write here: ") + std::strerror(errno));
  std::fclose(f);
}

}  // namespace rayfold::core
