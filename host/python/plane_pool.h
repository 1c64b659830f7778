// The memory of G-buffer planes that numpy has let go, kept for the next
// render of the same size. A render into fresh memory has the kernel fault
// in and zero every page of its planes (29 MB for a 720p frame of all
// channels), then zeroes them again (std::vector's resize) before the
// render writes them whole: 17 to 23 ms a frame on a 2-core machine, as
// long as the trace. A plane taken from here is written over in place,
// which is what Renderer::render_into does for C++ callers.
#pragma once

#include <cstddef>
#include <cstdint>
#include <deque>
#include <mutex>
#include <new>
#include <type_traits>
#include <vector>

namespace rayfold::python {

class PlanePool {
 public:
  template <class T>
  static constexpr bool kPooled = std::is_same_v<T, float> || std::is_same_v<T, uint32_t>;

  // A vector of exactly n elements holding stale values when one of that
  // size was given back (the newest), else an empty one (the render then
  // allocates).
  template <class T>
  std::vector<T> take(size_t n) {
    static_assert(kPooled<T>, "planes are float or uint32_t");
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = kept_.rbegin(); it != kept_.rend(); ++it) {
      std::vector<T>& v = it->template as<T>();
      if (v.size() != n || v.empty()) continue;
      std::vector<T> out = std::move(v);
      bytes_ -= it->bytes;
      kept_.erase(std::next(it).base());
      return out;
    }
    return {};
  }

  // Keeps v for take, the oldest kept ones freed to stay within kMaxBytes
  // and kMaxKept. Vectors under kMinBytes (malloc reuses those without the
  // kernel), over kMaxBytes, or not of a plane's type are simply freed.
  template <class T>
  void give(std::vector<T>&& v) noexcept {
    if constexpr (kPooled<T>) {
      const size_t bytes = v.size() * sizeof(T);
      if (bytes < kMinBytes || bytes > kMaxBytes) return;
      try {
        std::lock_guard<std::mutex> lock(mutex_);
        while (!kept_.empty() && (bytes_ + bytes > kMaxBytes || kept_.size() >= kMaxKept)) {
          bytes_ -= kept_.front().bytes;
          kept_.pop_front();
        }
        Kept k;
        k.bytes = bytes;
        k.template as<T>() = std::move(v);
        kept_.push_back(std::move(k));
        bytes_ += bytes;
      } catch (...) {  // out of memory for the list: v is simply freed
      }
    }
  }

  // In a forked child: another thread of the parent may have held the lock
  // at the fork, and no thread of the child will release it.
  void reset_lock_after_fork() { new (&mutex_) std::mutex; }

 private:
  static constexpr size_t kMinBytes = size_t{1} << 16;
  static constexpr size_t kMaxBytes = size_t{256} << 20;
  // A stream's views held a chunk at a time (rayfold.iter_views, 32) come
  // back together: room for all of a chunk's planes that fit the bytes.
  static constexpr size_t kMaxKept = 256;

  struct Kept {
    size_t bytes = 0;
    std::vector<float> floats;
    std::vector<uint32_t> words;
    template <class T>
    std::vector<T>& as() {
      if constexpr (std::is_same_v<T, float>)
        return floats;
      else
        return words;
    }
  };

  std::mutex mutex_;
  size_t bytes_ = 0;
  std::deque<Kept> kept_;  // oldest first
};

}  // namespace rayfold::python
