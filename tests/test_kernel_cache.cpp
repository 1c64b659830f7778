// Compiled programs kept between processes (opencl/kernel_cache.h): a second
// renderer takes its programs from the cache and traces the CPU reference's
// bits with them; a file that is not whole or not this key's is never used
// and is written again; each build option has its own file; a cache that is
// off or cannot be written changes nothing but the time.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

#include "opencl/kernel_cache.h"
#include "pipeline/pipeline.h"
#include "test_util.h"

namespace rayfold::core {
namespace {

namespace fs = std::filesystem;

// An environment variable for one test, restored after (unset: null).
class Env {
 public:
  Env(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old, had_ = true;
    if (value)
      setenv(name, value, 1);
    else
      unsetenv(name);
  }
  ~Env() {
    if (had_)
      setenv(name_, old_.c_str(), 1);
    else
      unsetenv(name_);
  }

 private:
  const char* name_;
  std::string old_;
  bool had_ = false;
};

std::string fresh_dir(const std::string& name) {
  const std::string dir = (fs::temp_directory_path() / ("rayfold-" + name + "-" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  return dir;
}

std::vector<fs::path> files_in(const std::string& dir) {
  std::vector<fs::path> out;
  if (fs::exists(dir))
    for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

struct Views {
  Scene scene;
  std::vector<Camera> cams;
  std::vector<HitBuffer> want;  // the CPU reference's
};

Views views() {
  testing::Rng rng(1234);
  Views v;
  v.scene = testing::random_scene(rng, 2, 6, 150);
  PipelineOptions cpu;
  cpu.backend = Backend::cpu;
  Pipeline ref(v.scene, cpu);
  for (int i = 0; i < 3; ++i) {
    v.cams.push_back(make_camera(testing::random_camera(rng, v.scene.world_bounds()), 48, 32));
    v.want.push_back(ref.render(v.cams.back()).hits);
  }
  return v;
}

// A renderer of this kernel made now (its program built or loaded) traces
// the reference's bits.
void expect_reference_bits(const Views& v, Kernel kernel, const std::string& what) {
  PipelineOptions o;
  o.kernel = kernel;
  Pipeline r(v.scene, o);
  for (size_t i = 0; i < v.cams.size(); ++i)
    EXPECT_EQ(testing::compare_hits(v.want[i], r.render(v.cams[i]).hits, v.cams[i].width), "")
        << what << ", kernel " << int(kernel) << ", view " << i;
}

TEST(KernelCache, SecondRendererLoadsItsProgramAndTracesTheSameBits) {
  const std::string dir = fresh_dir("kcache");
  const Env env("RAYFOLD_KERNEL_CACHE", dir.c_str());
  const Views v = views();
  const size_t before = kernel_cache_hits();
  expect_reference_bits(v, Kernel::tile, "built from source");
  EXPECT_EQ(kernel_cache_hits(), before);
  const std::vector<fs::path> stored = files_in(dir);
  ASSERT_EQ(stored.size(), 1u) << "one program, one file";
  EXPECT_EQ(stored[0].extension(), ".bin") << stored[0] << ": a temporary left behind";
  EXPECT_EQ(fs::status(dir).permissions() & (fs::perms::group_all | fs::perms::others_all), fs::perms::none)
      << "others may write the binaries this process runs";
  const fs::file_time_type written = fs::last_write_time(stored[0]);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  expect_reference_bits(v, Kernel::single, "loaded from the cache");
  expect_reference_bits(v, Kernel::tile, "loaded from the cache");
  EXPECT_EQ(kernel_cache_hits(), before + 2) << "the second and third renderers built from source";
  EXPECT_EQ(files_in(dir), stored);
  EXPECT_EQ(fs::last_write_time(stored[0]), written) << "a loaded program was stored again";
  // Another precision is another program: a file of its own, not a hit.
  PipelineOptions fast;
  fast.precision = KernelPrecision::fast;
  Pipeline f(v.scene, fast);
  f.render(v.cams[0]);
  EXPECT_EQ(kernel_cache_hits(), before + 2);
  EXPECT_EQ(files_in(dir).size(), 2u);
  fs::remove_all(dir);
}

// Each way a file can be wrong, applied to the stored bytes.
void damage_file(const fs::path& p, int how) {
  const auto size = static_cast<std::streamoff>(fs::file_size(p));
  if (how == 1) {  // cut short
    fs::resize_file(p, static_cast<uintmax_t>(size - 7));
    return;
  }
  std::fstream f(p, std::ios::in | std::ios::out | std::ios::binary);
  ASSERT_TRUE(f) << p;
  if (how == 2) {  // one byte more
    f.seekp(0, std::ios::end);
    f.put('\0');
    return;
  }
  // A byte flipped: 0 the binary's, 3 the magic's, 4 the key length's, 5 the
  // binary length's, 6 the checksum's, 7 the key's.
  const std::streamoff at[] = {size - 100, 0, 0, 3, 17, 25, 33, 41};
  f.seekg(at[how]);
  const int c = f.get();
  f.seekp(at[how]);
  f.put(static_cast<char>(c ^ 0x5a));
}

TEST(KernelCache, FilesNotWholeOrOfAnotherKeyAreNeverLoaded) {
  const std::string dir = fresh_dir("kcache-files");
  const std::vector<unsigned char> binary(3000, 7);
  for (int how = 0; how < 8; ++how) {
    ASSERT_TRUE(store_cached_program(dir, "the key", binary));
    ASSERT_EQ(load_cached_program(dir, "the key"), binary);
    const std::vector<fs::path> files = files_in(dir);
    ASSERT_EQ(files.size(), 1u);
    damage_file(files[0], how);
    EXPECT_TRUE(load_cached_program(dir, "the key").empty()) << "damage " << how << " was loaded";
  }
  // Another key whose name would be this one's: the name is a hash, the key
  // inside is compared whole.
  ASSERT_TRUE(store_cached_program(dir, "the key", binary));
  const fs::path file = files_in(dir)[0];
  ASSERT_TRUE(store_cached_program(dir, "the kez", binary));  // as long as the key
  fs::rename(files_in(dir)[0] == file ? files_in(dir)[1] : files_in(dir)[0], file);
  EXPECT_TRUE(load_cached_program(dir, "the key").empty()) << "another key's file loaded";
  fs::remove_all(dir);
}

TEST(KernelCache, ADamagedProgramIsBuiltAgainAndStoredWhole) {
  const std::string dir = fresh_dir("kcache-damaged");
  const Env env("RAYFOLD_KERNEL_CACHE", dir.c_str());
  const Views v = views();
  expect_reference_bits(v, Kernel::tile, "built from source");
  const std::vector<fs::path> stored = files_in(dir);
  ASSERT_EQ(stored.size(), 1u);
  for (int how : {0, 1, 2}) {
    damage_file(stored[0], how);
    const size_t hits = kernel_cache_hits();
    expect_reference_bits(v, Kernel::tile, "after damage " + std::to_string(how));
    EXPECT_EQ(kernel_cache_hits(), hits) << "a damaged file (damage " << how << ") was used";
    expect_reference_bits(v, Kernel::single, "after the rebuild");
    EXPECT_EQ(kernel_cache_hits(), hits + 1) << "damage " << how << " was not written over";
  }
  fs::remove_all(dir);
}

TEST(KernelCache, OffOrUnwritableChangesNothingButTheTime) {
  const Views v = views();
  for (const char* off : {"off", "OFF", "0", "none", ""}) {
    const Env env("RAYFOLD_KERNEL_CACHE", off);
    EXPECT_EQ(kernel_cache_dir(), "") << "'" << off << "'";
  }
  {
    const Env env("RAYFOLD_KERNEL_CACHE", "off");
    const size_t hits = kernel_cache_hits();
    expect_reference_bits(v, Kernel::tile, "cache off");
    expect_reference_bits(v, Kernel::tile, "cache off again");
    EXPECT_EQ(kernel_cache_hits(), hits);
  }
  // A folder that cannot be made: a path through a regular file (root may
  // write anywhere, so permissions cannot stand in for this).
  const std::string blocker = fresh_dir("kcache-blocker");
  std::ofstream(blocker) << "a file, not a folder";
  {
    const Env env("RAYFOLD_KERNEL_CACHE", (blocker + "/kernels").c_str());
    const size_t hits = kernel_cache_hits();
    expect_reference_bits(v, Kernel::tile, "cache unwritable");
    expect_reference_bits(v, Kernel::tile, "cache unwritable again");
    EXPECT_EQ(kernel_cache_hits(), hits);
  }
  EXPECT_FALSE(store_cached_program(blocker + "/kernels", "key", {1, 2, 3}));
  fs::remove(blocker);
}

TEST(KernelCache, FolderFromTheEnvironment) {
  const Env rf("RAYFOLD_KERNEL_CACHE", nullptr);
  {
    const Env xdg("XDG_CACHE_HOME", "/x/cache");
    const Env home("HOME", "/h");
    EXPECT_EQ(kernel_cache_dir(), "/x/cache/rayfold/kernels");
  }
  for (const char* not_absolute : {"", "relative/cache"}) {  // the XDG rule: ignored
    const Env xdg("XDG_CACHE_HOME", not_absolute);
    const Env home("HOME", "/h");
    EXPECT_EQ(kernel_cache_dir(), "/h/.cache/rayfold/kernels") << "XDG_CACHE_HOME '" << not_absolute << "'";
  }
  {
    const Env xdg("XDG_CACHE_HOME", nullptr);
    const Env home("HOME", nullptr);
    EXPECT_EQ(kernel_cache_dir(), "");
  }
  const Env set("RAYFOLD_KERNEL_CACHE", "rel/k");
  EXPECT_EQ(kernel_cache_dir(), (fs::current_path() / "rel/k").string());
}

TEST(KernelCache, KeepsItsNewestProgramsAndSweepsDeadWritersTemporaries) {
  const std::string dir = fresh_dir("kcache-prune");
  fs::create_directories(dir);
  const std::string stale = dir + "/.0123456789abcdef.bin.rayfold-999999999-0.tmp";
  std::ofstream(stale) << "a write its process never finished";
  const size_t extra = 3;
  for (size_t i = 0; i < kMaxCachedPrograms + extra; ++i) {
    ASSERT_TRUE(store_cached_program(dir, "key " + std::to_string(i), {static_cast<unsigned char>(i + 1)}));
    std::this_thread::sleep_for(std::chrono::milliseconds(5));  // distinct times, oldest first
  }
  EXPECT_FALSE(fs::exists(stale)) << "a dead writer's temporary kept";
  EXPECT_EQ(files_in(dir).size(), kMaxCachedPrograms);
  for (size_t i = 0; i < kMaxCachedPrograms + extra; ++i)
    EXPECT_EQ(load_cached_program(dir, "key " + std::to_string(i)).empty(), i < extra) << "key " << i;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rayfold::core
