#include "util/parallel.h"

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace rayfold::core {

unsigned resolve_threads(unsigned threads) {
  return threads ? threads : std::max(1u, std::thread::hardware_concurrency());
}

void parallel_for(size_t n, unsigned threads, size_t chunk, const std::function<void(size_t, size_t)>& body) {
  parallel_for_beside(n, threads, chunk, body, nullptr);
}

void parallel_for_beside(size_t n, unsigned threads, size_t chunk, const std::function<void(size_t, size_t)>& body,
                         const std::function<void()>& first) {
  chunk = std::max<size_t>(chunk, 1);
  std::atomic<size_t> next{0};
  // The first exception a chunk throws stops the hand-out and is rethrown on
  // the caller's thread once every thread has stopped.
  std::exception_ptr failure;
  std::mutex failure_mutex;
  auto worker = [&] {
    try {
      for (size_t begin; (begin = next.fetch_add(chunk)) < n;) body(begin, std::min(n, begin + chunk));
    } catch (...) {
      next = n;
      const std::lock_guard<std::mutex> lock(failure_mutex);
      if (!failure) failure = std::current_exception();
    }
  };
  // No more threads than chunks (and `first`): a small job runs on the
  // caller alone.
  const size_t useful = std::min<size_t>(resolve_threads(threads), (n + chunk - 1) / chunk + (first ? 1 : 0));
  std::vector<std::thread> pool;
  for (size_t t = 1; t < useful; ++t) pool.emplace_back(worker);
  if (first) {
    try {
      first();
    } catch (...) {
      next = n;
      for (std::thread& t : pool) t.join();
      throw;
    }
  }
  worker();
  for (std::thread& t : pool) t.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace rayfold::core
