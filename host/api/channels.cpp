#include "output/channels.h"
#include "rayfold/gbuffer.h"

namespace rayfold {

unsigned parse_channels(const std::string& list) { return core::parse_channels(list); }

}  // namespace rayfold
