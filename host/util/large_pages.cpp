#include "util/large_pages.h"

#include <atomic>
#include <cstdint>
#include <cstring>
#include <mutex>
#include <new>
#include <unordered_map>
#include <vector>

#ifdef __linux__
#include <pthread.h>
#include <sys/mman.h>
#endif

namespace rayfold::core {
namespace {

constexpr size_t kHugePage = size_t{2} << 20;

size_t mapped_size(size_t bytes) { return (bytes + kHugePage - 1) & ~(kHugePage - 1); }

}  // namespace

// Under AddressSanitizer the heap's aligned allocations, whose overruns it
// reports; mapped memory has no redzones.
#if defined(__SANITIZE_ADDRESS__)
#define RF_LARGE_PAGES_MAPPED 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define RF_LARGE_PAGES_MAPPED 0
#endif
#endif
#if !defined(RF_LARGE_PAGES_MAPPED) && defined(__linux__)
#define RF_LARGE_PAGES_MAPPED 1
#endif

#if RF_LARGE_PAGES_MAPPED

namespace {

// The blocks free_large keeps, oldest first, and the size of each block
// handed out (a kept block may be larger than the array it serves).
struct KeptBlocks {
  struct Block {
    void* p;
    size_t size;
  };
  std::mutex mutex;
  std::vector<Block> kept;
  size_t kept_bytes = 0;
  std::unordered_map<void*, size_t> given;
};

// BuildScopes alive in the process, and on this thread: a forked child has
// only the forking thread, so it keeps that thread's count.
std::atomic<int> g_building{0};
thread_local int t_building = 0;

KeptBlocks& kept_blocks() {
  // Never destroyed: arrays may be freed during static destruction. A fork
  // (Python's multiprocessing) takes the mutex first and both sides let go
  // of it after, so that a child never starts with it held by a thread it
  // does not have.
  static KeptBlocks* blocks = [] {
    auto* b = new KeptBlocks;
    pthread_atfork([] { kept_blocks().mutex.lock(); }, [] { kept_blocks().mutex.unlock(); },
                   [] {
                     g_building = t_building;
                     kept_blocks().mutex.unlock();
                   });
    return b;
  }();
  return *blocks;
}

// Made, and its fork handlers set, as the library loads: made on first
// use, a fork during that first use (a thread's first large array) left
// the child waiting on the initialisation's guard.
[[maybe_unused]] const KeptBlocks& kKeptAtLoad = kept_blocks();

void* map_fresh(size_t size) {
  // Over-mapped by one huge page, then trimmed to a 2 MiB boundary at both
  // ends: only whole, aligned 2 MiB ranges can be huge pages.
  void* raw = mmap(nullptr, size + kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (raw == MAP_FAILED) throw std::bad_alloc();
  const uintptr_t start = reinterpret_cast<uintptr_t>(raw);
  const uintptr_t aligned = (start + kHugePage - 1) & ~(uintptr_t{kHugePage} - 1);
  if (aligned > start) munmap(raw, aligned - start);
  const uintptr_t end = start + size + kHugePage, used_end = aligned + size;
  if (end > used_end) munmap(reinterpret_cast<void*>(used_end), end - used_end);
  void* p = reinterpret_cast<void*>(aligned);
#ifdef MADV_HUGEPAGE
  madvise(p, size, MADV_HUGEPAGE);  // a hint: refused, the pages are 4 KiB ones
#endif
  return p;
}

}  // namespace

void* allocate_large(size_t bytes) {
  const size_t size = mapped_size(bytes);
  KeptBlocks& b = kept_blocks();
  {
    std::lock_guard<std::mutex> lock(b.mutex);
    size_t best = b.kept.size();
    for (size_t k = 0; k < b.kept.size(); ++k)
      if (b.kept[k].size >= size && b.kept[k].size / 2 <= size &&
          (best == b.kept.size() || b.kept[k].size < b.kept[best].size))
        best = k;
    if (best < b.kept.size()) {
      const KeptBlocks::Block block = b.kept[best];
      b.given[block.p] = block.size;  // first: should it throw, the block is still kept
      b.kept.erase(b.kept.begin() + static_cast<std::ptrdiff_t>(best));
      b.kept_bytes -= block.size;
      return block.p;
    }
  }
  void* p = map_fresh(size);
  try {
    std::lock_guard<std::mutex> lock(b.mutex);
    b.given[p] = size;
  } catch (...) {
    munmap(p, size);
    throw std::bad_alloc();
  }
  return p;
}

void free_large(void* p, size_t bytes) noexcept {
  KeptBlocks& b = kept_blocks();
  std::vector<KeptBlocks::Block> unmap;
  size_t size = mapped_size(bytes);
  try {
    std::lock_guard<std::mutex> lock(b.mutex);
    const auto given = b.given.find(p);
    if (given != b.given.end()) {
      size = given->second;
      b.given.erase(given);
    }
    unmap.reserve(b.kept.size() + 1);
    b.kept.reserve(b.kept.size() + 1);
    bool keep = size <= kKeptLargeBytes && g_building.load() == 0;
#ifdef MADV_FREE
    keep = keep && madvise(p, size, MADV_FREE) == 0;  // kernels before 4.5 refuse: then unmapped
#else
    keep = false;
#endif
    if (!keep) {
      unmap.push_back({p, size});
    } else {
      // The oldest go first: a rebuild asks for what was freed last.
      size_t drop = 0;
      while (b.kept_bytes + size > kKeptLargeBytes) {
        unmap.push_back(b.kept[drop]);
        b.kept_bytes -= b.kept[drop++].size;
      }
      b.kept.erase(b.kept.begin(), b.kept.begin() + static_cast<std::ptrdiff_t>(drop));
      b.kept.push_back({p, size});
      b.kept_bytes += size;
    }
  } catch (...) {  // no memory for the bookkeeping: the block goes back now
    unmap.clear();
    munmap(p, size);
    return;
  }
  for (const KeptBlocks::Block& block : unmap) munmap(block.p, block.size);
}

BuildScope::BuildScope() {
  ++g_building;
  ++t_building;
}
BuildScope::~BuildScope() {
  --g_building;
  --t_building;
}

void release_kept_large_arrays() noexcept {
  KeptBlocks& b = kept_blocks();
  std::vector<KeptBlocks::Block> unmap;
  {
    std::lock_guard<std::mutex> lock(b.mutex);
    unmap.swap(b.kept);
    b.kept_bytes = 0;
  }
  for (const KeptBlocks::Block& block : unmap) munmap(block.p, block.size);
}

void poison_kept_large_arrays(unsigned char byte) noexcept {
  KeptBlocks& b = kept_blocks();
  std::lock_guard<std::mutex> lock(b.mutex);
  for (const KeptBlocks::Block& block : b.kept) std::memset(block.p, byte, block.size);
}

size_t kept_large_bytes() noexcept {
  KeptBlocks& b = kept_blocks();
  std::lock_guard<std::mutex> lock(b.mutex);
  return b.kept_bytes;
}

bool large_arrays_are_mapped() { return true; }

#else

void* allocate_large(size_t bytes) { return ::operator new (bytes, std::align_val_t{kHugePage}); }

void free_large(void* p, size_t) noexcept { ::operator delete (p, std::align_val_t{kHugePage}); }

BuildScope::BuildScope() {}
BuildScope::~BuildScope() {}

void release_kept_large_arrays() noexcept {}

void poison_kept_large_arrays(unsigned char) noexcept {}

size_t kept_large_bytes() noexcept { return 0; }

bool large_arrays_are_mapped() { return false; }

#endif

}  // namespace rayfold::core
