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

// The caller runs `first` while the other threads take the chunks, then
// takes chunks too: every item once, `first` once and on the caller, the
// chunks begun before it ends when there is another thread; on one
// thread, `first` and then every chunk.
TEST(Parallel, BesideRunsFirstOnTheCallerWhileOthersTakeChunks) {
  for (unsigned threads : {1u, 2u, 4u}) {
    const std::thread::id caller = std::this_thread::get_id();
    std::vector<std::atomic<int>> seen(400);
    std::atomic<int> firsts{0}, done_during_first{0};
    std::atomic<bool> in_first{false}, first_started{false};
    parallel_for_beside(
        seen.size(), threads, 4,
        [&](size_t begin, size_t end) {
          // Held until `first` has begun, so that the other threads cannot
          // finish every chunk before it.
          for (int wait = 0; wait < 2000 && !first_started; ++wait)
            std::this_thread::sleep_for(std::chrono::microseconds(100));
          for (size_t i = begin; i < end; ++i) seen[i]++;
          if (in_first) done_during_first++;
        },
        [&] {
          EXPECT_EQ(std::this_thread::get_id(), caller);
          firsts++;
          in_first = true;
          first_started = true;
          for (int wait = 0; wait < 2000 && done_during_first == 0 && threads > 1; ++wait)
            std::this_thread::sleep_for(std::chrono::microseconds(100));
          in_first = false;
        });
    EXPECT_EQ(firsts.load(), 1) << threads << " threads";
    for (size_t i = 0; i < seen.size(); ++i)
      ASSERT_EQ(seen[i].load(), 1) << "item " << i << ", " << threads << " threads";
    if (threads > 1) {
      EXPECT_GT(done_during_first.load(), 0) << "no chunk ran beside `first`, " << threads << " threads";
    } else {
      EXPECT_EQ(done_during_first.load(), 0) << "a chunk ran during `first` on one thread";
    }
  }
}

// An exception from `first` reaches the caller once the other threads stop.
TEST(Parallel, AnExceptionFromFirstStopsTheChunks) {
  std::atomic<int> chunks{0};
  try {
    parallel_for_beside(
        1000, 2, 1,
        [&](size_t, size_t) {
          chunks++;
          std::this_thread::sleep_for(std::chrono::microseconds(50));
        },
        [] { throw std::runtime_error("first"); });
    FAIL() << "parallel_for_beside returned normally";
  } catch (const std::runtime_error& e) {
    EXPECT_STREQ(e.what(), "first");
  }
  EXPECT_LT(chunks.load(), 1000) << "the chunks went on after `first` threw";
}

}  // namespace
}  // namespace rayfold::core
