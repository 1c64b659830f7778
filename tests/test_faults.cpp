// Fault injection: the command-line tool under full disks (a real tmpfs of
// a chosen size, mounted in a private mount namespace), signals at random
// points of a run, read-only and missing folders, and two runs writing the
// same file. Each case asserts the exit code, the message and what is left
// on disk: a run's outputs land together or not at all, and no temporary
// file stays behind.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <thread>

#include "output/image_output.h"
#include "test_util.h"
#include "util/atomic_file.h"

extern char** environ;

namespace rayfold::core {
namespace {

namespace fs = std::filesystem;

struct Outcome {
  int code = -1;
  std::string err;
};

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

fs::path fresh_dir(const std::string& name) {
  const fs::path d = testing::scratch_dir("rayfold_faults") / name;
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::vector<std::string> listing(const fs::path& d) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(d)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

std::string joined(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += n + " ";
  return s.empty() ? "(nothing)" : s;
}

Outcome shell(const std::string& command, const fs::path& scratch) {
  const std::string err = (scratch / "stderr").string();
  const int status = std::system((command + " 2>" + err + " >/dev/null").c_str());
  Outcome r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  r.err = read_text(err);
  return r;
}

const std::string kRender = std::string(RAYFOLD_BIN) + " render -q";

// How this machine makes a private mount namespace: "unshare -rm" (a user
// namespace, no root needed), else "unshare -m" (root); "" when neither works
// (a container without either), and the tmpfs cases skip.
const std::string& private_mount() {
  static const std::string how = [] {
    const fs::path probe = testing::scratch_dir("rayfold_faults_probe");
    std::string found;
    for (const char* u : {"unshare -rm", "unshare -m"}) {
      const std::string cmd =
          std::string(u) + " sh -c 'mount -t tmpfs -o size=65536 tmpfs " + probe.string() + "' >/dev/null 2>&1";
      if (std::system(cmd.c_str()) == 0) {
        found = u;
        break;
      }
    }
    fs::remove_all(probe);
    return found;
  }();
  return how;
}

// Runs `args` with `mount` as a fresh tmpfs of `bytes` (its listing afterwards
// in `files`); false when this machine cannot make a private mount.
bool render_in_tmpfs(size_t bytes, const std::string& args, const fs::path& scratch, Outcome* run,
                     std::vector<std::string>* files) {
  const fs::path mount = scratch / "mnt", list = scratch / "listing";
  fs::create_directories(mount);
  const std::string script = "mount -t tmpfs -o size=" + std::to_string(bytes) + " tmpfs " + mount.string() +
                             " || exit 99; cd " + mount.string() + "; " + kRender + " " + args + "; code=$?; ls -A > " +
                             list.string() + "; exit $code";
  if (private_mount().empty()) return false;
  *run = shell(private_mount() + " sh -c '" + script + "'", scratch);
  if (run->code == 99) return false;
  files->clear();
  std::istringstream in(read_text(list));
  for (std::string line; std::getline(in, line);) files->push_back(line);
  return true;
}

size_t pages(size_t bytes) { return (bytes + 4095) / 4096 * 4096; }

// The disk fills at each output in turn: at the EXR, at the PNG after the
// EXR was written, at the stats after both, and in the middle of a camera
// list. Before, the PNG writer reported success on a truncated file, the
// run exited 2 and the files written before the failure stayed.
TEST(Faults, AFullDiskAtEveryOutputLeavesNothing) {
  const fs::path d = fresh_dir("full");
  const std::string args = "--size 200x120 -o a.exr --png a.png --stats a.json";
  const fs::path ref = fresh_dir("full_reference");
  ASSERT_EQ(shell("cd " + ref.string() + " && " + kRender + " " + args, d).code, 0);
  const size_t exr = pages(fs::file_size(ref / "a.exr")), png = pages(fs::file_size(ref / "a.png"));
  struct Case {
    size_t bytes;
    const char* failing;
  };
  for (const Case& c : {Case{exr / 2, "a.exr"}, Case{exr + png / 2, "a.png"}, Case{exr + png, "a.json"}}) {
    Outcome r;
    std::vector<std::string> files;
    if (!render_in_tmpfs(c.bytes, args, d, &r, &files))
      GTEST_SKIP() << "cannot mount a tmpfs here (unshare -rm needs user namespaces, unshare -m root)";
    EXPECT_EQ(r.code, 3) << c.failing << ": " << r.err;
    EXPECT_NE(r.err.find(std::string(c.failing) + ": cannot write"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("No space left on device"), std::string::npos) << r.err;
    EXPECT_TRUE(files.empty()) << "full at " << c.failing << " left: " << joined(files);
  }
  // A camera list of four views, the disk full at the third.
  std::ofstream(d / "list.json") << R"({"width": 200, "height": 120, "cameras": [
      {"eye": [0, 3, 12], "look_at": [0, 2, 0]}, {"eye": [1, 3, 12], "look_at": [0, 2, 0]},
      {"eye": [2, 3, 12], "look_at": [0, 2, 0]}, {"eye": [3, 3, 12], "look_at": [0, 2, 0]}]})";
  Outcome r;
  std::vector<std::string> files;
  ASSERT_TRUE(
      render_in_tmpfs(2 * exr + exr / 2, "--cameras " + (d / "list.json").string() + " -o v_%02d.exr", d, &r, &files));
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_NE(r.err.find(".exr: cannot write the EXR file: No space left"), std::string::npos) << r.err;
  EXPECT_TRUE(files.empty()) << joined(files);
  // A file-size limit through prlimit: the write fails (SIGXFSZ is ignored)
  // instead of the process dying. On the CPU backend: PoCL's compiler
  // writes files of its own and stops the process when it cannot.
  const Outcome limited = shell("cd " + d.string() + " && prlimit --fsize=" + std::to_string(exr / 2) + " " + kRender +
                                    " --backend cpu --size 200x120 -o limited.exr",
                                d);
  EXPECT_EQ(limited.code, 3) << limited.err;
  EXPECT_NE(limited.err.find("limited.exr: cannot write the EXR file"), std::string::npos) << limited.err;
  EXPECT_FALSE(fs::exists(d / "limited.exr"));
}

pid_t spawn(const std::vector<std::string>& args, const fs::path& err) {
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return rc == 0 ? pid : -1;
}

int wait_code(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 1000 + WTERMSIG(status);
}

// SIGINT, SIGTERM and SIGHUP at random moments of loading, building,
// tracing and writing (a seeded spread over the run's length): the exit code
// is 128 + the signal and nothing is left, or the run had finished and every
// output is complete. Before, an interrupted EXR write left its temporary.
// A signal before main (the dynamic loader, the sanitizer's start) kills the
// process by the default action; that too must leave nothing (CI met one at
// 18 ms under AddressSanitizer).
TEST(Faults, SignalsAtRandomPointsLeaveNothing) {
  const fs::path d = fresh_dir("signals");
  const std::vector<std::string> args = {RAYFOLD_BIN,
                                         "render",
                                         "-q",
                                         "--size",
                                         "1600x900",
                                         "--frames",
                                         "2",
                                         "-o",
                                         (d / "s.exr").string(),
                                         "--png",
                                         (d / "s.png").string(),
                                         "--stats",
                                         (d / "s.json").string()};
  // How long a whole run takes here, to spread the signals over it.
  const auto t0 = std::chrono::steady_clock::now();
  ASSERT_EQ(wait_code(spawn(args, d / "err")), 0) << read_text(d / "err");
  const double run_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  for (const fs::path& f : {d / "s.exr", d / "s.png", d / "s.json"}) fs::remove(f);
  // How long the process takes to reach main and install its handlers (the
  // longest of three runs that stop there): a signal before that meets the
  // default action and kills the process before it has done anything. Under
  // AddressSanitizer this is tens of milliseconds.
  double startup_s = 0.0;
  for (int k = 0; k < 3; ++k) {
    const auto s0 = std::chrono::steady_clock::now();
    ASSERT_EQ(wait_code(spawn({RAYFOLD_BIN, "--help"}, d / "err")), 0) << read_text(d / "err");
    startup_s = std::max(startup_s, std::chrono::duration<double>(std::chrono::steady_clock::now() - s0).count());
  }
  fs::remove(d / "err");
  // A signal this soon after the spawn may still meet the default action:
  // three quiet starts do not bound one on a machine busy with other tests
  // (ctest -j2 here: a start of a few ms met SIGINT's default at 7.8 ms).
  const double before_main_s = std::max(2.0 * startup_s, startup_s + 0.02);
  std::mt19937 rng(1901);
  std::uniform_real_distribution<double> when(0.0, 1.1 * run_s);
  const int signals[] = {SIGINT, SIGTERM, SIGHUP};
  int interrupted = 0, handled = 0;
  for (int k = 0; k < 9; ++k) {
    const int sig = signals[k % 3];
    const double at = when(rng);
    const pid_t pid = spawn(args, d / "err");
    ASSERT_GT(pid, 0);
    std::this_thread::sleep_for(std::chrono::duration<double>(at));
    kill(pid, sig);
    const int code = wait_code(pid);
    const std::string err = read_text(d / "err");
    fs::remove(d / "err");
    const std::vector<std::string> files = listing(d);
    if (code == 0) {  // finished before the signal
      EXPECT_EQ(files, (std::vector<std::string>{"s.exr", "s.json", "s.png"})) << joined(files);
      for (const std::string& f : files) fs::remove(d / f);
      continue;
    }
    ++interrupted;
    if (code == 1000 + sig && at <= before_main_s) {  // before main: nothing can have been written
      EXPECT_EQ(err, "") << "signal " << sig << " at " << at << " s";
      EXPECT_TRUE(files.empty()) << "signal " << sig << " at " << at << " s left: " << joined(files);
      continue;
    }
    ++handled;
    EXPECT_EQ(code, 128 + sig) << "signal " << sig << " at " << at << " s (start-up " << startup_s << " s): " << err;
    EXPECT_NE(err.find("no output written"), std::string::npos) << err;
    EXPECT_TRUE(files.empty()) << "signal " << sig << " at " << at << " s left: " << joined(files);
  }
  EXPECT_GE(interrupted, 5) << "the signals mostly came after the run; the spread is wrong";
  // The handlers themselves must have been met: most signals land well after start-up.
  EXPECT_GE(handled, 3) << "too few signals met the handlers (start-up " << startup_s << " s)";
}

// Read-only folders and a file where a folder should be fail before any
// work, with exit 2, naming the path. Root writes through permission bits,
// so the read-only folder is a read-only mount where one can be made.
TEST(Faults, ReadOnlyFoldersAndFilesInThePathFailFirst) {
  const fs::path d = fresh_dir("readonly");
  std::ofstream(d / "file.txt") << "not a folder";
  Outcome r = shell(kRender + " --size 32x18 -o " + (d / "file.txt/x.exr").string(), d);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("file.txt/x.exr: cannot write here: Not a directory"), std::string::npos) << r.err;
  const fs::path mount = d / "ro";
  fs::create_directories(mount);
  if (private_mount().empty()) GTEST_SKIP() << "cannot make a private mount here (unshare -rm or -m)";
  r = shell(private_mount() + " sh -c 'mount -t tmpfs -o ro tmpfs " + mount.string() + " || exit 99; " + kRender +
                " --size 32x18 -o " + (mount / "x.exr").string() + "'",
            d);
  if (r.code == 99) GTEST_SKIP() << "cannot mount a read-only tmpfs here";
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_NE(r.err.find("x.exr: cannot write here: Read-only file system"), std::string::npos) << r.err;
}

// Missing output folders are made as mkdir -p makes them, also where a
// frame field names the folder; a run that fails removes the folders it
// made, and only those.
TEST(Faults, MissingFoldersAreMadeAndRemovedWhenTheRunFails) {
  const fs::path d = fresh_dir("folders");
  Outcome r = shell(kRender + " --size 32x18 --frames 2 -o " + (d / "a/b/x.exr").string() + " --png " +
                        (d / "seq/%02d/y.png").string(),
                    d);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(fs::is_regular_file(d / "a/b/x.exr"));
  EXPECT_TRUE(fs::is_regular_file(d / "seq/00/y.png"));
  EXPECT_TRUE(fs::is_regular_file(d / "seq/01/y.png"));
  fs::create_directories(d / "kept");
  r = shell(kRender + " " + (d / "missing.glb").string() + " -o " + (d / "new/deeper/x.exr").string() + " --png " +
                (d / "kept/y.png").string(),
            d);
  EXPECT_EQ(r.code, 2) << r.err;
  EXPECT_FALSE(fs::exists(d / "new")) << "a failed run left the folder it made";
  EXPECT_TRUE(fs::is_directory(d / "kept")) << "a failed run removed a folder it did not make";
}

// Two renders of different views into the same file at once: both succeed,
// the file is whole (one of the two images) and no temporary is left.
TEST(Faults, TwoRunsWritingOneFileLeaveOneWholeFile) {
  const fs::path d = fresh_dir("race");
  const std::string out = (d / "same.exr").string();
  for (int round = 0; round < 3; ++round) {
    const pid_t a =
        spawn({RAYFOLD_BIN, "render", "-q", "--size", "800x450", "--eye", "0,3,12", "--look-at", "0,2,0", "-o", out},
              d / "err_a");
    const pid_t b =
        spawn({RAYFOLD_BIN, "render", "-q", "--size", "800x450", "--eye", "4,3,12", "--look-at", "0,2,0", "-o", out},
              d / "err_b");
    EXPECT_EQ(wait_code(a), 0) << read_text(d / "err_a");
    EXPECT_EQ(wait_code(b), 0) << read_text(d / "err_b");
    int w = 0, h = 0;
    EXPECT_EQ(read_exr(out, &w, &h).size(), 800u * 450u);
    fs::remove(d / "err_a");
    fs::remove(d / "err_b");
    EXPECT_EQ(listing(d), std::vector<std::string>{"same.exr"}) << joined(listing(d));
  }
}

// Temporaries of a run that was killed outright (SIGKILL cannot be caught)
// are removed by the next run into the folder; a live process's and a
// user's files are not.
TEST(Faults, StaleTemporariesAreRemovedByTheNextRun) {
  const fs::path d = fresh_dir("stale");
  const pid_t gone = spawn({"/bin/true"}, d / "err");
  wait_code(gone);
  const std::string dead = std::to_string(gone), live = std::to_string(::getpid());
  // A zombie (ended, not reaped) has ended too: where no one reaps orphans,
  // a killed batch worker stays one (a rerun kept its temporary).
  const pid_t zombie = ::fork();
  if (zombie == 0) ::_exit(0);
  ASSERT_GT(zombie, 0);
  for (int i = 0; i < 200 && read_text("/proc/" + std::to_string(zombie) + "/stat").find(") Z") == std::string::npos;
       ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  for (const std::string& name :
       {".a.exr.rayfold-" + dead + "-0.tmp", ".old.png.rayfold-" + dead + "-7.tmp", "a.exr.tmp-" + dead,
        ".b.exr.rayfold-" + live + "-0.tmp", std::string("notes.tmp"), ".x.rayfold-" + dead + "-y.tmp",
        ".z.exr.rayfold-" + std::to_string(zombie) + "-3.tmp"})
    std::ofstream(d / name) << "partial";
  fs::remove(d / "err");
  const Outcome r = shell(kRender + " --size 32x18 -o " + (d / "a.exr").string(), d);
  ::waitpid(zombie, nullptr, 0);
  ASSERT_EQ(r.code, 0) << r.err;
  fs::remove(d / "stderr");
  EXPECT_EQ(listing(d), (std::vector<std::string>{".b.exr.rayfold-" + live + "-0.tmp", ".x.rayfold-" + dead + "-y.tmp",
                                                  "a.exr", "notes.tmp"}))
      << joined(listing(d));
  // SIGKILL mid-run, then a clean run: the killed run's temporary goes.
  const fs::path k = fresh_dir("killed");
  const pid_t pid =
      spawn({RAYFOLD_BIN, "render", "-q", "--size", "3000x2000", "-o", (k / "big.exr").string()}, d / "e");
  ASSERT_GT(pid, 0);
  bool writing = false;
  for (int i = 0; i < 400 && !writing; ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(25));
    for (const std::string& f : listing(k))  // the EXR's, not the empty probe of the start
      writing |= f.find(".rayfold-") != std::string::npos && fs::file_size(k / f) > 0;
  }
  kill(pid, SIGKILL);
  wait_code(pid);
  ASSERT_TRUE(writing) << "never saw the run's temporary file";
  ASSERT_EQ(shell(kRender + " --size 16x9 -o " + (k / "small.exr").string(), d).code, 0);
  EXPECT_EQ(listing(k), std::vector<std::string>{"small.exr"}) << joined(listing(k));
}

}  // namespace
}  // namespace rayfold::core
