// Memory for the build's large arrays (triangles, nodes, the builder's
// records) and a frame's hits, in 2 MiB pages where the system has them.
//
// Why: every array the build writes is fresh memory, and on the machines
// this project is measured on a fresh 4 KiB page costs a fault of about
// 2 us (64 MiB touched: 26 to 35 ms in 4 KiB pages, 8 ms in 2 MiB ones).
// The conference room's build writes about 70 MB of them, a fifth of its
// time on two threads; a new process's first G-buffer pays it whole.
// Linux gives 2 MiB pages to a mapping that asks for them (madvise
// MADV_HUGEPAGE) when transparent huge pages are "always" or "madvise";
// elsewhere, or when the kernel says no, the mapping keeps 4 KiB pages and
// nothing else changes.
#pragma once

#include <cstddef>
#include <new>
#include <type_traits>
#include <utility>

namespace rayfold::core {

// Arrays of at least this many bytes are mapped on their own, except under
// AddressSanitizer, which guards only the heap's arrays with redzones.
constexpr size_t kLargeArrayBytes = size_t{4} << 20;

// Arrays freed outside a build (a scene's trees when it is dropped or
// rebuilt) are kept for the next ones (a rebuild asks for the same sizes
// again), up to kKeptLargeBytes in all, their pages handed back to the
// kernel lazily (MADV_FREE: reclaimed only under memory pressure, and then
// faulted in fresh again). Fresh pages cost every rebuild a tenth of its
// time in faults and zeroing (the car, the conference room), where
// Embree's rebuilds in one process take none after the second (its
// allocator keeps its blocks too). Arrays freed during a build
// (BuildScope) are unmapped: kept, a build's first arrays stayed resident
// beside its later ones, and the car's build peaked at 239 bytes a
// triangle rather than 140.
constexpr size_t kKeptLargeBytes = size_t{512} << 20;

// `bytes` (at least kLargeArrayBytes) of memory aligned to 2 MiB, asked
// for in 2 MiB pages: a kept block of at least that size and at most twice
// it, else a fresh mapping; its contents are undefined. Throws
// std::bad_alloc when it cannot be had.
void* allocate_large(size_t bytes);
// Returns what allocate_large gave for the same `bytes`: kept for reuse
// outside a build while the kept blocks stay within kKeptLargeBytes (the
// oldest unmapped first), else unmapped.
void free_large(void* p, size_t bytes) noexcept;

// While one lives (on any thread), freed arrays are unmapped, not kept:
// for the span of a build, whose temporary arrays would otherwise raise
// its peak.
class BuildScope {
 public:
  BuildScope();
  ~BuildScope();
  BuildScope(const BuildScope&) = delete;
  BuildScope& operator=(const BuildScope&) = delete;
};

// Unmaps every kept block: before measuring a build's peak memory, which
// kept blocks would hide.
void release_kept_large_arrays() noexcept;
// The bytes kept for reuse now.
size_t kept_large_bytes() noexcept;
// Fills every kept block with `byte`: for tests, so that a byte an array's
// producer leaves unwritten shows as a difference between two builds.
void poison_kept_large_arrays(unsigned char byte) noexcept;

// Whether allocate_large maps its memory and asks for 2 MiB pages (Linux,
// not under AddressSanitizer), rather than taking it from the heap.
bool large_arrays_are_mapped();

// A fixed number of T whose elements start uninitialised, each written
// before it is read: for arrays filled in one pass, which a std::vector
// would zero first. No constructor runs (T trivially copyable and
// destructible; a default member initialiser, as Aabb's, is skipped: the
// element is assigned whole). At least kLargeArrayBytes come from
// allocate_large.
template <class T>
class LargeArray {
  static_assert(std::is_trivially_copyable_v<T> && std::is_trivially_destructible_v<T>);

 public:
  LargeArray() = default;
  explicit LargeArray(size_t n) : size_(n) {
    if (bytes() >= kLargeArrayBytes)
      data_ = static_cast<T*>(allocate_large(bytes()));
    else if (n > 0)
      data_ = static_cast<T*>(::operator new (bytes(), std::align_val_t{alignof(T)}));
  }
  LargeArray(LargeArray&& o) noexcept : data_(std::exchange(o.data_, nullptr)), size_(std::exchange(o.size_, 0)) {}
  LargeArray& operator=(LargeArray&& o) noexcept {
    std::swap(data_, o.data_);
    std::swap(size_, o.size_);
    return *this;
  }
  LargeArray(const LargeArray&) = delete;
  LargeArray& operator=(const LargeArray&) = delete;
  ~LargeArray() {
    if (!data_) return;
    if (bytes() >= kLargeArrayBytes)
      free_large(data_, bytes());
    else
      ::operator delete (data_, std::align_val_t{alignof(T)});
  }

  T* data() { return data_; }
  const T* data() const { return data_; }
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  T& operator[](size_t i) { return data_[i]; }
  const T& operator[](size_t i) const { return data_[i]; }

 private:
  size_t bytes() const { return size_ * sizeof(T); }
  T* data_ = nullptr;
  size_t size_ = 0;
};

}  // namespace rayfold::core
