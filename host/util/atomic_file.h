// Output files are written under a temporary name next to the target and
// renamed into place only when complete, so a failure never leaves a partial
// file under the name the user asked for. Within an OutputTransaction
// (host/util/output_transaction.h) the rename waits for the whole run.
#pragma once

#include <cstddef>
#include <string>

namespace rayfold::core {

class AtomicFile {
 public:
  // The temporary name is "<dir>/.<name>.rayfold-<pid>-<n>.tmp": hidden, in
  // the target's folder (so the rename cannot cross file systems), and
  // recognisable as rayfold's by a later run (remove_stale_temporaries).
  explicit AtomicFile(std::string path);
  ~AtomicFile();  // removes the temporary file unless committed
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::string& temp_path() const { return temp_; }
  const std::string& path() const { return path_; }
  // The file is complete: renamed into place now, or handed to the open
  // OutputTransaction to be renamed with the others. RuntimeFailure naming
  // the file when the rename fails.
  void commit();
  // Instead of commit(): renamed into place now even while an
  // OutputTransaction is open, for files that are not a run's output (a
  // cache) and stand on their own. RuntimeFailure naming the file when the
  // rename fails.
  void commit_now();

 private:
  std::string path_, temp_;
  void* entry_;  // the temporary's entry in the signal-time cleanup list
  bool committed_ = false;
};

// Writes bytes to an open AtomicFile's temporary name, checking every write
// and the close (a full disk often shows only there). RuntimeFailure naming
// the file on failure.
void write_temp_bytes(const AtomicFile& file, const void* data, size_t size);

// Writes text to path atomically; RuntimeFailure on failure.
void write_text_file(const std::string& path, const std::string& text);

// Throws InputError(path, ...) unless a file can be created at path; run
// before expensive work so a bad output path fails fast. Also removes the
// folder's stale temporaries (remove_stale_temporaries).
void check_writable(const std::string& path);

// Makes the folders a path's file goes in that do not exist yet, as mkdir -p
// does (the command-line tools' outputs; a library call refuses a missing
// folder, as Python's open does). Within an OutputTransaction a failed run
// removes them again. InputError naming the path when one cannot be made.
void make_output_folders(const std::string& path);

// Removes rayfold's temporary files in `folder` whose process has ended (an
// earlier run killed mid-write), and the older "<name>.tmp-<pid>" ones of
// `target`. Returns how many were removed.
size_t remove_stale_temporaries(const std::string& folder, const std::string& target = "");

}  // namespace rayfold::core
