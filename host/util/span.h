// A read-only view of contiguous elements, for functions that read arrays
// held in vectors of any allocator (C++17 has no std::span): a frame's hits
// (page-aligned, renderer.h) and a copy of them in a std::vector alike.
#pragma once

#include <cstddef>
#include <vector>

namespace rayfold::core {

template <class T>
class ConstSpan {
 public:
  ConstSpan(const T* data, size_t size) : data_(data), size_(size) {}
  template <class Alloc>
  ConstSpan(const std::vector<T, Alloc>& v) : data_(v.data()), size_(v.size()) {}  // NOLINT: implicit by design

  const T* data() const { return data_; }
  size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }
  const T& operator[](size_t i) const { return data_[i]; }
  const T* begin() const { return data_; }
  const T* end() const { return data_ + size_; }

 private:
  const T* data_;
  size_t size_;
};

}  // namespace rayfold::core
