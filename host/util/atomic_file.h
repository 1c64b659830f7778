// Output files are written under a temporary name next to the target and
// renamed into place only when complete, so a failure never leaves a partial
// file under the name the user asked for.
#pragma once

#include <string>

namespace rayfold::core {

class AtomicFile {
 public:
  explicit AtomicFile(std::string path);
  ~AtomicFile();  // removes the temporary file unless committed
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::string& temp_path() const { return temp_; }
  const std::string& path() const { return path_; }
  // Renames the temporary file into place; throws InputError on failure.
  void commit();

 private:
  std::string path_, temp_;
  bool committed_ = false;
};

// Writes text to path atomically; InputError on failure.
void write_text_file(const std::string& path, const std::string& text);

// Throws InputError(path, ...) unless a file can be created at path; run
// before expensive work so a bad output path fails fast.
void check_writable(const std::string& path);

}  // namespace rayfold::core
