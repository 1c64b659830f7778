// The build's large arrays (util/large_pages.h): where they start, that
// every element holds what was written, and that on a Linux with
// transparent huge pages they fault in 2 MiB at a time.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <fstream>
#include <string>
#include <thread>

#include "util/large_pages.h"
#include "util/page_aligned.h"

#ifdef __linux__
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>
#endif

namespace rayfold::core {
namespace {

constexpr uintptr_t kHugePage = uintptr_t{2} << 20;

TEST(LargePages, LargeArraysStartOnA2MiBPageAndKeepEveryElement) {
  for (size_t n :
       {size_t{1}, size_t{1000}, kLargeArrayBytes / 8 - 1, kLargeArrayBytes / 8, 3 * kLargeArrayBytes / 8 + 5}) {
    LargeArray<uint64_t> a(n);
    ASSERT_EQ(a.size(), n);
    const bool large = n * sizeof(uint64_t) >= kLargeArrayBytes;
    EXPECT_EQ(reinterpret_cast<uintptr_t>(a.data()) % (large ? kHugePage : alignof(uint64_t)), 0u)
        << n << " elements at " << a.data();
    for (size_t i = 0; i < n; ++i) a[i] = i * 0x9E3779B97F4A7C15ull;
    LargeArray<uint64_t> moved(std::move(a));
    EXPECT_TRUE(a.empty());
    for (size_t i = 0; i < n; ++i) ASSERT_EQ(moved[i], i * 0x9E3779B97F4A7C15ull) << "element " << i << " of " << n;
  }
}

TEST(LargePages, PageAlignedVectorsGrowAcrossTheLargeSizeWithTheirContents) {
  PageAlignedVector<uint32_t> v;
  for (uint32_t i = 0; i < 3 * kLargeArrayBytes / sizeof(uint32_t); ++i) {
    v.push_back(i * 2654435761u);
    if ((i & (i + 1)) == 0) {
      ASSERT_EQ(reinterpret_cast<uintptr_t>(v.data()) % 4096, 0u) << v.size() << " elements";
    }
  }
  EXPECT_EQ(reinterpret_cast<uintptr_t>(v.data()) % kHugePage, 0u);
  for (uint32_t i = 0; i < v.size(); ++i) ASSERT_EQ(v[i], i * 2654435761u) << "element " << i;
}

#ifdef __linux__
long minor_faults() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return u.ru_minflt;
}

// The kernel's count of huge-page faults that fell back to 4 KiB pages
// (no free 2 MiB page, a cgroup's limit), -1 where it is not kept.
long thp_fallbacks() {
  std::ifstream vmstat("/proc/vmstat");
  std::string name;
  long value = 0;
  while (vmstat >> name >> value)
    if (name == "thp_fault_fallback") return value;
  return -1;
}

// What the arrays are for: 32 MiB written for the first time take a few
// dozen faults, not one per 4 KiB page (8192), where the kernel gives
// transparent huge pages to a mapping that asks.
TEST(LargePages, FreshLargeArraysFaultInWholeHugePages) {
  if (!large_arrays_are_mapped()) GTEST_SKIP() << "large arrays come from the heap in this build (AddressSanitizer)";
  std::ifstream thp("/sys/kernel/mm/transparent_hugepage/enabled");
  std::string mode;
  std::getline(thp, mode);
  if (mode.find("[always]") == std::string::npos && mode.find("[madvise]") == std::string::npos)
    GTEST_SKIP() << "transparent huge pages are off here ('" << mode << "')";
  constexpr size_t kBytes = size_t{32} << 20;
  release_kept_large_arrays();  // a kept block would have no fresh pages to fault
  LargeArray<char> a(kBytes);
  const long fallbacks = thp_fallbacks();
  const long before = minor_faults();
  for (size_t i = 0; i < kBytes; i += 4096) a[i] = 1;
  const long faults = minor_faults() - before;
  if (faults >= static_cast<long>(kBytes / 4096 / 4) && thp_fallbacks() > fallbacks)
    GTEST_SKIP() << "the kernel had no 2 MiB pages to give (thp_fault_fallback rose; " << faults << " faults)";
  EXPECT_LT(faults, static_cast<long>(kBytes / 4096 / 4)) << "faults for " << kBytes / 4096 << " fresh 4 KiB pages";
}

// A rebuild asks for the sizes the last build freed: it gets those blocks
// back, pages and all, rather than fresh ones to fault in.
TEST(LargePages, FreedLargeArraysServeTheNextOfTheirSize) {
  if (!large_arrays_are_mapped()) GTEST_SKIP() << "large arrays come from the heap in this build (AddressSanitizer)";
  release_kept_large_arrays();
  constexpr size_t kBytes = size_t{24} << 20;
  const void* first = nullptr;
  {
    LargeArray<char> a(kBytes);
    first = a.data();
    for (size_t i = 0; i < kBytes; i += 4096) a[i] = 1;
  }
  if (kept_large_bytes() == 0) GTEST_SKIP() << "the kernel refuses MADV_FREE (before Linux 4.5): nothing is kept";
  EXPECT_EQ(kept_large_bytes(), kBytes);
  LargeArray<char> again(kBytes - 100);
  EXPECT_EQ(static_cast<const void*>(again.data()), first);
  EXPECT_EQ(kept_large_bytes(), 0u);
  const long before = minor_faults();
  for (size_t i = 0; i < kBytes - 100; i += 4096) again[i] = 2;
  EXPECT_LT(minor_faults() - before, static_cast<long>(kBytes / 4096 / 4)) << "faults writing a kept block";
  { LargeArray<char> moved(std::move(again)); }  // kept again, whole
  EXPECT_EQ(kept_large_bytes(), kBytes);
  {
    // A smaller array (at least half the block) takes the whole block, and
    // gives it back whole.
    LargeArray<char> smaller(kBytes * 3 / 5);
    EXPECT_EQ(static_cast<const void*>(smaller.data()), first);
    EXPECT_EQ(kept_large_bytes(), 0u);
  }
  EXPECT_EQ(kept_large_bytes(), kBytes) << "the block, not the smaller array's size";
  release_kept_large_arrays();
}

// The resident set's size in bytes (/proc/self/statm), 0 where unknown.
size_t resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  size_t pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * 4096;
}

// Arrays freed during a build are unmapped, not kept: a build's first
// arrays are not resident beside its later ones, and its peak is what it
// was without keeping. After it, freed arrays are kept again.
TEST(LargePages, ArraysFreedDuringABuildAreNotKept) {
  if (!large_arrays_are_mapped()) GTEST_SKIP() << "large arrays come from the heap in this build (AddressSanitizer)";
  release_kept_large_arrays();
  constexpr size_t kBytes = size_t{16} << 20;
  {
    const BuildScope building;
    const size_t resident = resident_bytes();
    {
      LargeArray<char> a(kBytes);
      for (size_t i = 0; i < kBytes; i += 4096) a[i] = 1;
    }
    EXPECT_EQ(kept_large_bytes(), 0u);
    if (resident > 0) {
      EXPECT_LT(resident_bytes(), resident + kBytes / 2) << "the freed array still resident";
    }
  }
  { LargeArray<char> b(kBytes); }
  if (kept_large_bytes() == 0) GTEST_SKIP() << "the kernel refuses MADV_FREE (before Linux 4.5): nothing is kept";
  EXPECT_EQ(kept_large_bytes(), kBytes);
  release_kept_large_arrays();
}

// What is kept stays within kKeptLargeBytes, the oldest blocks unmapped
// first. Address space only: none of these pages is touched.
TEST(LargePages, KeptBlocksStayWithinTheirCapOldestFirst) {
  if (!large_arrays_are_mapped()) GTEST_SKIP() << "large arrays come from the heap in this build (AddressSanitizer)";
  release_kept_large_arrays();
  constexpr size_t kBytes = kKeptLargeBytes / 2 - (size_t{2} << 20);
  const void* last = nullptr;
  {
    LargeArray<char> a(kBytes), b(kBytes), c(kBytes);
    last = c.data();
  }  // freed c, b, a: a is the newest
  if (kept_large_bytes() == 0) GTEST_SKIP() << "the kernel refuses MADV_FREE (before Linux 4.5): nothing is kept";
  EXPECT_EQ(kept_large_bytes(), 2 * kBytes) << "of three blocks of " << kBytes << " under a cap of " << kKeptLargeBytes;
  LargeArray<char> x(kBytes), y(kBytes), z(kBytes);
  EXPECT_NE(static_cast<const void*>(x.data()), last);
  EXPECT_NE(static_cast<const void*>(y.data()), last);
  EXPECT_EQ(kept_large_bytes(), 0u);
  release_kept_large_arrays();
}

// A fork while another thread allocates and frees large arrays (Python's
// multiprocessing forks a process whose threads may be building): every
// child can still allocate one. Without the fork handlers a child could
// start with the kept blocks' lock held by a thread it does not have, and
// hang on its first large array (each child here dies by its alarm after
// 2 s instead: with the handlers removed, 22 and 28 of 40 did).
TEST(LargePages, ForkedChildrenAllocateWhileAThreadKeepsBlocks) {
  if (!large_arrays_are_mapped()) GTEST_SKIP() << "large arrays come from the heap in this build (AddressSanitizer)";
  std::atomic<bool> stop{false};
  std::thread churn([&] {
    while (!stop) {
      LargeArray<char> a(kLargeArrayBytes), b(2 * kLargeArrayBytes);
      a[0] = b[0] = 1;
    }
  });
  int failed = 0;
  for (int k = 0; k < 40; ++k) {
    const pid_t child = fork();
    if (child == 0) {
      alarm(2);
      LargeArray<char> mine(3 * kLargeArrayBytes);
      mine[0] = 1;
      _exit(0);
    }
    int status = 0;
    EXPECT_GT(child, 0) << "fork failed";
    if (child < 0) break;
    waitpid(child, &status, 0);
    failed += !(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  }
  stop = true;
  churn.join();
  EXPECT_EQ(failed, 0) << "children of 40 that did not allocate and exit";
  release_kept_large_arrays();
}
#endif

}  // namespace
}  // namespace rayfold::core
