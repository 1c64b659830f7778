#include "output/channels.h"

#include <algorithm>
#include <utility>

#include "util/errors.h"

namespace rayfold::core {

unsigned parse_channels(const std::string& list) {
  static const std::pair<const char*, unsigned> kNames[] = {
      {"Z", kDepth},         {"N", kNormal},           {"UV", kUv},  {"InstanceID", kInstanceId},
      {"PrimitiveID", kPrimitiveId}, {"depth", kDepth}, {"normal", kNormal}, {"uv", kUv},
      {"instance_id", kInstanceId},  {"primitive_id", kPrimitiveId}, {"t", kDepth}};
  unsigned mask = 0;
  for (size_t start = 0; start <= list.size();) {
    const size_t end = std::min(list.find(',', start), list.size());
    std::string name = list.substr(start, end - start);
    name.erase(0, name.find_first_not_of(' '));
    name.erase(name.find_last_not_of(' ') + 1);
    start = end + 1;
    if (name.empty() && list.find_first_not_of(" ,") == std::string::npos) break;
    bool known = false;
    for (const auto& [n, bit] : kNames)
      if (name == n) {
        mask |= bit;
        known = true;
      }
    if (!known)
      throw InputError("", "channels: unknown channel '" + name +
                               "' (Z, N, UV, InstanceID, PrimitiveID; or depth, normal, uv, instance_id, "
                               "primitive_id; t is another name for depth, as ray queries call it)");
  }
  if (mask == 0) throw InputError("", "channels: name at least one channel");
  return mask;
}

}  // namespace rayfold::core
