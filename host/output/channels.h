// The G-buffer's planes, one table: each plane's channel bit, its names
// (Python's, the CLI's --channels, the EXR's), its values per pixel and
// where a rayfold::GBuffer holds it. Every writer, reader and parser of
// planes goes through it, so a channel is added here once.
#pragma once

#include <string>
#include <vector>

#include "rayfold/gbuffer.h"

namespace rayfold::core {

struct PlaneSpec {
  unsigned bit;           // rayfold::Channels
  const char* name;       // Python's plane and --channels' name
  const char* alias;      // another name accepted (an older one), or nullptr
  const char* exr_layer;  // the EXR's name for the whole plane, also accepted by --channels
  int components;         // values per pixel
  const char* exr[4];     // the EXR channel of each component
  // Where a GBuffer holds it: floats (FLOAT in an EXR) or ids (UINT).
  std::vector<float> GBuffer::*floats;
  std::vector<uint32_t> GBuffer::*ids;
};

// In Channels' bit order.
const std::vector<PlaneSpec>& plane_specs();

// A comma-separated list of plane names as Channels: the names, aliases or
// EXR layer names of plane_specs() ("depth,normal", "Z,N"), spaces around a
// name ignored. InputError naming an unknown name, or for an empty list.
unsigned parse_channels(const std::string& list);

}  // namespace rayfold::core
