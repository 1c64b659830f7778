// The one checksum of files rayfold writes and reads back (scene files,
// cached kernels): FNV-1a over 8-byte words, then the last bytes one by one,
// so that a damaged file is found at a few GB/s rather than byte-wise FNV's
// one. Not a defence against deliberate change.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

namespace rayfold::core {

inline uint64_t fnv1a(const char* p, size_t n) {
  uint64_t h = 0xcbf29ce484222325ull;
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    uint64_t word;
    std::memcpy(&word, p + i, 8);
    h = (h ^ word) * 0x100000001b3ull;
  }
  for (; i < n; ++i) h = (h ^ static_cast<unsigned char>(p[i])) * 0x100000001b3ull;
  return h;
}

}  // namespace rayfold::core
