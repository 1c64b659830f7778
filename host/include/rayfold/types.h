// The plain value types of rayfold's public API: no GLM, no OpenCL.
#pragma once

#include <array>
#include <cstdint>

namespace rayfold {

using Vec3 = std::array<double, 3>;

// A 4x4 affine transform, row-major (m[4 * row + column]); the last row is
// 0 0 0 1. Transforms are named destination-from-source: world_from_object
// takes object-space points to world space.
using Matrix4 = std::array<double, 16>;
// The transform that leaves points where they are: an instance placed with
// it stands where its mesh's own coordinates put it.
inline constexpr Matrix4 kIdentity = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};

// instance_id and primitive_id of a pixel that hits nothing.
inline constexpr uint32_t kMiss = 0xFFFFFFFFu;

// How an EXR's pixels are compressed: OpenEXR's lossless methods only, so
// that every float and id reads back bit for bit. zip (the default) is the
// smallest here; none writes 3 to 4 times faster at 10 times the bytes.
enum class ExrCompression { none, rle, zips, zip, piz };

// Which tracer renders; both give the same bits.
enum class Backend {
  opencl,  // the OpenCL kernels, on the device RendererOptions::device names
  cpu,     // the CPU reference tracer: the same algorithm, the same bits
};

// Which OpenCL kernel traces; every choice gives the same bits.
enum class Kernel {
  automatic,  // tile on CPU devices, measured on the first render elsewhere
  tile,       // 16x16 ray tiles in vector lanes (fastest on CPUs)
  single,     // one ray per work-item (fastest on GPUs)
  measure,    // trace the first render with both and keep the faster, on any device
};

}  // namespace rayfold
