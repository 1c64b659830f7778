// The host's work splitter: every item once, and a failure reaches the caller.
#include <gtest/gtest.h>

#include <atomic>
#include <stdexcept>
#include <thread>
#include <vector>

#include "util/parallel.h"

namespace rayfold::core {
namespace {

TEST(Parallel, EveryItemOnceOnAnyThreadCount) {
  for (unsigned threads : {1u, 2u, 5u}) {
    std::vector<std::atomic<int>> seen(1000);
    parallel_for(seen.size(), threads, 7, [&](size_t begin, size_t end) {
      for (size_t i = begin; i < end; ++i) seen[i]++;
    });
    for (size_t i = 0; i < seen.size(); ++i)
      ASSERT_EQ(seen[i].load(), 1) << "item " << i << ", " << threads << " threads";
  }
}

// A throw on a worker thread used to end the process (std::terminate).
TEST(Parallel, AnExceptionReachesTheCallerFromAnyThread) {
  const std::thread::id caller = std::this_thread::get_id();
  std::atomic<bool> thrown_elsewhere{false};
  try {
    parallel_for(64, 4, 1, [&](size_t begin, size_t) {
      if (std::this_thread::get_id() != caller || begin == 63) {
        thrown_elsewhere = std::this_thread::get_id() != caller;
        throw std::runtime_error("chunk " + std::to_string(begin));
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    });
    FAIL() << "parallel_for returned normally";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()).rfind("chunk ", 0), 0u) << e.what();
  }
  EXPECT_TRUE(thrown_elsewhere.load()) << "no worker thread ran a chunk";
}

}  // namespace
}  // namespace rayfold::core
