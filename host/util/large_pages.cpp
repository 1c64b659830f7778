#include "util/large_pages.h"

#include <cstdint>
#include <new>

#ifdef __linux__
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

void* allocate_large(size_t bytes) {
  const size_t size = mapped_size(bytes);
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

void free_large(void* p, size_t bytes) noexcept { munmap(p, mapped_size(bytes)); }

bool large_arrays_are_mapped() { return true; }

#else

void* allocate_large(size_t bytes) { return ::operator new(bytes, std::align_val_t{kHugePage}); }

void free_large(void* p, size_t) noexcept { ::operator delete(p, std::align_val_t{kHugePage}); }

bool large_arrays_are_mapped() { return false; }

#endif

}  // namespace rayfold::core
