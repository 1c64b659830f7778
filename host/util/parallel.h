// The host's one way to spread work over cores: items [0, n) are handed out
// in chunks from an atomic counter, so uneven items (meshes, rows of rays)
// balance themselves.
#pragma once

#include <cstddef>
#include <functional>

namespace rayfold::core {

// 0 means every core the machine reports (at least 1).
unsigned resolve_threads(unsigned threads);

// Calls body(begin, end) over [0, n) in chunks of `chunk` items on `threads`
// threads (the caller's included); returns when all are done. An exception
// from body stops the remaining chunks and is rethrown here.
void parallel_for(size_t n, unsigned threads, size_t chunk, const std::function<void(size_t, size_t)>& body);
// The same, the caller first running `first` (if set) while the other
// threads take chunks: serial work beside a parallel loop. An exception
// from `first` stops the chunks and is rethrown once the threads stop.
void parallel_for_beside(size_t n, unsigned threads, size_t chunk, const std::function<void(size_t, size_t)>& body,
                         const std::function<void()>& first);

}  // namespace rayfold::core
