// Buffers over host memory, shared by the frame and query tracers: a CPU
// device (PoCL) reads and writes the host's arrays in place, any other
// device gets copies.
#pragma once

#include <cstring>

#include "opencl/cl_device.h"

namespace rayfold::core {

// OpenCL refuses zero-sized buffers; every buffer gets at least one element.
inline size_t at_least_one(size_t n) { return n ? n : 1; }

// A read-only buffer over a scene array (triangles, wide nodes, query
// trees): on a CPU device that memory itself (read-only, page-aligned:
// util/page_aligned.h, and kept by its owner for as long as the buffer);
// elsewhere a copy in a buffer of `bytes` (at least one element).
template <class Array>
cl::Buffer host_array_buffer(ClDevice& device, const Array& v, size_t bytes) {
  using T = typename Array::value_type;
  cl::Context& ctx = device.context();
  if (device.info().is_cpu && !v.empty())
    return cl::Buffer(ctx, CL_MEM_READ_ONLY | CL_MEM_USE_HOST_PTR, v.size() * sizeof(T), const_cast<T*>(v.data()));
  cl::Buffer b(ctx, CL_MEM_READ_ONLY, bytes);
  if (!v.empty()) device.queue().enqueueWriteBuffer(b, CL_FALSE, 0, v.size() * sizeof(T), v.data());
  return b;
}

// Hands a buffer over host memory back to the host, synchronised: on a CPU
// device mapping gives that memory itself, without a copy.
inline void sync_host_buffer(cl::CommandQueue& q, const cl::Buffer& buf, void* host, size_t bytes) {
  void* m = q.enqueueMapBuffer(buf, CL_TRUE, CL_MAP_READ, 0, bytes);
  if (m != host) std::memcpy(host, m, bytes);
  q.enqueueUnmapMemObject(buf, m);
}

}  // namespace rayfold::core
