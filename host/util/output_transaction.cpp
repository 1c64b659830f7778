#include "util/output_transaction.h"

#include <signal.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <utility>
#include <vector>

#include "util/errors.h"

namespace rayfold::core {
namespace {

// A singly linked list, only ever pushed at the head, so that a signal
// handler can walk it at any moment without a lock.
struct Entry {
  char* path;
  std::atomic<bool> live{true};
  Entry* next = nullptr;
};
std::atomic<Entry*> g_head{nullptr};

std::atomic<bool> g_committing{false};
std::atomic<int> g_pending_signal{0};

struct Staged {
  std::string temp, path;
  Entry* entry;
};
std::mutex g_mutex;  // guards g_open and g_staged
bool g_open = false;
std::vector<Staged> g_staged;
std::vector<std::string> g_created_folders;  // in the order made, parents first

void remove_live_temporaries() {
  for (Entry* e = g_head.load(); e; e = e->next)
    if (e->live.load()) ::unlink(e->path);
}

void write_stderr(const char* text) {
  ssize_t ignored = ::write(STDERR_FILENO, text, std::strlen(text));
  (void)ignored;
}

[[noreturn]] void exit_interrupted(int sig) {
  write_stderr(sig == SIGINT    ? "error: interrupted (SIGINT); no output written\n"
               : sig == SIGTERM ? "error: terminated (SIGTERM); no output written\n"
                                : "error: hung up (SIGHUP); no output written\n");
  ::_exit(128 + sig);
}

// Async-signal-safe: unlink, write and _exit only.
void on_signal(int sig) {
  if (g_committing.load()) {
    g_pending_signal.store(sig);  // commit() undoes its renames and exits
    return;
  }
  remove_live_temporaries();
  exit_interrupted(sig);
}

}  // namespace

void* register_temporary(const std::string& temp) {
  Entry* e = new Entry;
  e->path = new char[temp.size() + 1];
  std::memcpy(e->path, temp.c_str(), temp.size() + 1);
  e->next = g_head.load();
  while (!g_head.compare_exchange_weak(e->next, e)) {
  }
  return e;
}

void release_temporary(void* entry) {
  if (entry) static_cast<Entry*>(entry)->live.store(false);
}

OutputTransaction::OutputTransaction() {
  const std::lock_guard<std::mutex> lock(g_mutex);
  RF_CHECK(!g_open, "one output transaction at a time");
  g_open = true;
}

OutputTransaction::~OutputTransaction() {
  const std::lock_guard<std::mutex> lock(g_mutex);
  for (const Staged& s : g_staged) {
    std::remove(s.temp.c_str());
    release_temporary(s.entry);
  }
  g_staged.clear();
  // Folders the run made for its outputs go too, deepest first, when the
  // run left nothing else in them (rmdir refuses a folder that is not empty).
  for (auto f = g_created_folders.rbegin(); f != g_created_folders.rend(); ++f) ::rmdir(f->c_str());
  g_created_folders.clear();
  g_open = false;
}

bool OutputTransaction::adopt_folder(const std::string& folder) {
  const std::lock_guard<std::mutex> lock(g_mutex);
  if (!g_open) return false;
  g_created_folders.push_back(folder);
  return true;
}

bool OutputTransaction::adopt(const std::string& temp, const std::string& path, void* entry) {
  const std::lock_guard<std::mutex> lock(g_mutex);
  if (!g_open) return false;
  g_staged.push_back({temp, path, static_cast<Entry*>(entry)});
  return true;
}

void OutputTransaction::commit() {
  const std::lock_guard<std::mutex> lock(g_mutex);
  g_committing.store(true);
  std::vector<const Staged*> renamed;
  renamed.reserve(g_staged.size());
  std::string failure;
  for (const Staged& s : g_staged) {
    if (g_pending_signal.load()) break;
    if (std::rename(s.temp.c_str(), s.path.c_str()) != 0) {
      failure = s.path + ": cannot move the finished file into place: " + std::strerror(errno);
      break;
    }
    renamed.push_back(&s);
  }
  g_committing.store(false);
  const int sig = g_pending_signal.load();
  if (failure.empty() && !sig) {
    for (const Staged& s : g_staged) release_temporary(s.entry);
    g_staged.clear();
    g_created_folders.clear();
    return;
  }
  // Undone: the renamed files go, the rest are removed by the destructor.
  for (const Staged* s : renamed) {
    std::remove(s->path.c_str());
    release_temporary(s->entry);
  }
  if (sig) {
    for (const Staged& s : g_staged) std::remove(s.temp.c_str());
    remove_live_temporaries();
    exit_interrupted(sig);
  }
  throw RuntimeFailure(failure);
}

void install_interrupt_cleanup() {
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) sigaction(sig, &action, nullptr);
  ::signal(SIGXFSZ, SIG_IGN);
}

}  // namespace rayfold::core
