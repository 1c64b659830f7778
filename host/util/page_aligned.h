// Arrays that start on a page: the scene's large read-only arrays (the
// triangles, the wide nodes), which a CPU OpenCL device then reads where
// they are (CL_MEM_USE_HOST_PTR, opencl/cl_tracer.cpp) instead of from a
// copy. The copy cost the dragon's first frame 61 ms of fresh pages and
// memcpy, and held its 870k triangles twice. A page is more than any
// device's base address alignment (PoCL asks 128 bytes), so a kernel's
// vector loads see the alignment they would in a buffer of their own.
// A frame's hits (renderer.h, HitBuffer) take it too, for the
// default-initialising resize below: the kernels write every pixel.
// Large arrays are mapped in 2 MiB pages (util/large_pages.h).
#pragma once

#include <cstddef>
#include <new>
#include <type_traits>
#include <utility>
#include <vector>

#include "util/large_pages.h"

namespace rayfold::core {

template <class T>
struct PageAlignedAllocator {
  using value_type = T;
  static constexpr std::align_val_t kPage{4096};

  PageAlignedAllocator() = default;
  template <class U>
  PageAlignedAllocator(const PageAlignedAllocator<U>&) noexcept {}

  T* allocate(size_t n) {
    const size_t bytes = n * sizeof(T);
    return static_cast<T*>(bytes >= kLargeArrayBytes ? allocate_large(bytes) : ::operator new(bytes, kPage));
  }
  void deallocate(T* p, size_t n) noexcept {
    if (n * sizeof(T) >= kLargeArrayBytes)
      free_large(p, n * sizeof(T));
    else
      ::operator delete(p, kPage);
  }

  // resize(n) and emplace_back() default-initialise: a device struct
  // (rf_tri, rf_node, rf_wide_node) is left as it was, to be written whole
  // by its producer, where value-initialising zeroed the car's 17 MB of
  // triangles on one thread before the fill wrote them on all. A type with
  // a constructor still runs it.
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }

  template <class U>
  bool operator==(const PageAlignedAllocator<U>&) const noexcept {
    return true;
  }
  template <class U>
  bool operator!=(const PageAlignedAllocator<U>&) const noexcept {
    return false;
  }
};

template <class T>
using PageAlignedVector = std::vector<T, PageAlignedAllocator<T>>;

}  // namespace rayfold::core
