#include <algorithm>
#include <cstring>

#include "output/channels.h"
#include "rayfold/errors.h"
#include "rayfold/gbuffer.h"

namespace rayfold {

unsigned parse_channels(const std::string& list) { return core::parse_channels(list); }

size_t count_differing_pixels(const GBuffer& a, const GBuffer& b) {
  if (a.width != b.width || a.height != b.height || a.channels != b.channels)
    throw InputError("", "count_differing_pixels: G-buffers of " + std::to_string(a.width) + "x" +
                             std::to_string(a.height) + " (channels " + std::to_string(a.channels) + ") and " +
                             std::to_string(b.width) + "x" + std::to_string(b.height) + " (channels " +
                             std::to_string(b.channels) + ") do not compare pixel by pixel");
  const size_t n = static_cast<size_t>(a.width) * a.height;
  std::vector<char> differs(n, 0);
  auto compare = [&](const char* name, const auto& x, const auto& y) {
    if (x.size() != y.size())
      throw InputError("", std::string("count_differing_pixels: the ") + name + " planes hold " +
                               std::to_string(x.size()) + " and " + std::to_string(y.size()) + " values");
    if (x.empty()) return;
    const size_t per_pixel = x.size() / n;
    for (size_t i = 0; i < x.size(); ++i)
      if (std::memcmp(&x[i], &y[i], sizeof x[i]) != 0) differs[i / per_pixel] = 1;
  };
  // Every plane the G-buffer has, the resolved ones too.
  for (const core::PlaneSpec& p : core::plane_specs()) {
    if (p.floats) compare(p.name, a.*p.floats, b.*p.floats);
    if (p.ids) compare(p.name, a.*p.ids, b.*p.ids);
  }
  return static_cast<size_t>(std::count(differs.begin(), differs.end(), 1));
}

}  // namespace rayfold
