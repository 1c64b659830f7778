// All or nothing: every output of one run is renamed into place only when
// the run has succeeded, and a failed or interrupted run leaves none of
// them, neither under its final name nor as a temporary file.
#pragma once

#include <string>

namespace rayfold::core {

// At most one is open at a time; while it is, AtomicFile::commit() hands the
// finished temporary file to it instead of renaming it.
class OutputTransaction {
 public:
  OutputTransaction();
  ~OutputTransaction();  // not committed: removes every temporary handed over
  OutputTransaction(const OutputTransaction&) = delete;
  OutputTransaction& operator=(const OutputTransaction&) = delete;

  // Renames every finished file into place. A signal during the renames
  // (install_interrupt_cleanup) or a failed rename removes the files already
  // renamed again; the failure is a RuntimeFailure naming the file.
  void commit();

  // Called by AtomicFile::commit(); false when no transaction is open.
  static bool adopt(const std::string& temp, const std::string& path, void* entry);
  // A folder made for the run's outputs (make_output_folders): a run that
  // fails removes it again if it is empty. False when no transaction is open.
  static bool adopt_folder(const std::string& folder);
};

// The list of temporary files a signal removes. An entry's memory stays
// until the process ends (a signal handler may be reading it); release()
// takes the file off the list.
void* register_temporary(const std::string& temp);
void release_temporary(void* entry);

// SIGINT, SIGTERM and SIGHUP remove every temporary output file of the
// process (finished or not) and exit with 128 + the signal number (130,
// 143, 129); SIGXFSZ is ignored, so a file-size limit fails the write
// (exit 3) instead of killing the process. For command-line tools.
void install_interrupt_cleanup();

}  // namespace rayfold::core
