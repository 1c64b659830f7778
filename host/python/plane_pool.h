// The memory of G-buffer planes that numpy has let go, kept for the next
// render of the same size. A render into fresh memory has the kernel fault
// in and zero every page of its planes (29 MB for a 720p frame of all
// channels), then zeroes them again (std::vector's resize) before the
// render writes them whole; a plane taken from here is written over in
// place, which is what Renderer::render_into does for C++ callers.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <mutex>
#include <type_traits>
#include <vector>

namespace rayfold::python {

class PlanePool {
 public:
  // A vector of exactly n elements holding stale values when one of that
  // size was given back, else an empty one (the render then allocates).
  template <class T>
  std::vector<T> take(size_t n) {
    static_assert(kPooled<T>, "planes are float or uint32_t");
    std::lock_guard<std::mutex> lock(mutex_);
    auto& shelf = shelf_of<T>();
    auto it = shelf.find(n);
    if (it == shelf.end() || it->second.empty()) return {};
    std::vector<T> v = std::move(it->second.back());
    it->second.pop_back();
    bytes_ -= n * sizeof(T);
    return v;
  }

  // Keeps v for take, unless kPerSize vectors of its size or kMaxBytes in
  // all are kept already, or it is not a plane's type (then it is freed).
  template <class T>
  void give(std::vector<T>&& v) noexcept {
    if constexpr (kPooled<T>) {
      try {
        std::lock_guard<std::mutex> lock(mutex_);
        const size_t bytes = v.size() * sizeof(T);
        auto& kept = shelf_of<T>()[v.size()];
        if (v.empty() || kept.size() >= kPerSize || bytes_ + bytes > kMaxBytes) return;
        kept.push_back(std::move(v));
        bytes_ += bytes;
      } catch (...) {  // out of memory for the shelf: v is simply freed
      }
    }
  }

  template <class T>
  static constexpr bool kPooled = std::is_same_v<T, float> || std::is_same_v<T, uint32_t>;

 private:
  // Two frames of the two id planes (one size, one type): a loop that
  // rebinds its G-buffer lets the previous one go after the next is made.
  static constexpr size_t kPerSize = 4;
  static constexpr size_t kMaxBytes = size_t{256} << 20;

  template <class T>
  std::map<size_t, std::vector<std::vector<T>>>& shelf_of();

  std::mutex mutex_;
  size_t bytes_ = 0;
  std::map<size_t, std::vector<std::vector<float>>> floats_;
  std::map<size_t, std::vector<std::vector<uint32_t>>> words_;
};

template <>
inline std::map<size_t, std::vector<std::vector<float>>>& PlanePool::shelf_of<float>() {
  return floats_;
}
template <>
inline std::map<size_t, std::vector<std::vector<uint32_t>>>& PlanePool::shelf_of<uint32_t>() {
  return words_;
}

}  // namespace rayfold::python
