#include "util/parallel.h"

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace rayfold::core {

unsigned resolve_threads(unsigned threads) {
  return threads ? threads : std::max(1u, std::thread::hardware_concurrency());
}

void parallel_for(size_t n, unsigned threads, size_t chunk, const std::function<void(size_t, size_t)>& body) {
  chunk = std::max<size_t>(chunk, 1);
  std::atomic<size_t> next{0};
  auto worker = [&] {
    for (size_t begin; (begin = next.fetch_add(chunk)) < n;) body(begin, std::min(n, begin + chunk));
  };
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < resolve_threads(threads); ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
}

}  // namespace rayfold::core
