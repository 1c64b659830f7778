// The names of the G-buffer's planes (rayfold::Channels), as the CLI's
// --channels and Python's channels= spell them.
#pragma once

#include <string>

#include "rayfold/gbuffer.h"

namespace rayfold::core {

// A comma-separated list of plane names as Channels: the EXR channel names
// (Z, N, UV, InstanceID, PrimitiveID) or the Python plane names (depth,
// normal, uv, instance_id, primitive_id), spaces around a name ignored.
// InputError naming an unknown name, or for an empty list.
unsigned parse_channels(const std::string& list);

}  // namespace rayfold::core
