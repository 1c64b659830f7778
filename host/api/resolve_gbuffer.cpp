#include "api/resolve_gbuffer.h"

#include "resolve/resolve.h"
#include "util/errors.h"

namespace rayfold::detail {

static_assert(kDefaultMaterial == core::kDefaultMaterial, "one default material id");

unsigned attributes_for(unsigned channels) {
  return ((channels & kShadingNormal) ? core::kAttributeNormal : 0u) |
         ((channels & kTexcoord) ? core::kAttributeTexcoord0 : 0u) |
         ((channels & kTexcoord1) ? core::kAttributeTexcoord1 : 0u) |
         ((channels & kMaterialId) ? core::kAttributeMaterial : 0u);
}

unsigned trace_channels(unsigned channels) {
  unsigned trace = channels & kAllChannels;
  if (channels & kResolvedChannels) trace |= kInstanceId | kPrimitiveId | kBarycentrics;
  if (channels & kShadingNormal) trace |= kNormal;
  return trace;
}

std::vector<std::string> load_attributes(SceneState& s, unsigned attributes) {
  if (attributes == 0) return {};
  if (s.file && (s.file->attributes() & attributes) != attributes) {
    s.file->set_attributes(s.file->attributes() | attributes);
    core::Scene posed = s.file->scene_at(s.time);
    // The file's meshes come first (add_mesh appends), posed as they are.
    RF_CHECK_LE(posed.meshes.size(), s.scene.meshes.size(), "the file posed again has more meshes");
    for (size_t m = 0; m < posed.meshes.size(); ++m) {
      RF_CHECK_EQ(posed.meshes[m].positions.size(), s.scene.meshes[m].positions.size(),
                  "the file posed again has another mesh");
      s.scene.meshes[m].attributes = std::move(posed.meshes[m].attributes);
    }
  }
  const unsigned unnamed = attributes & ~s.attributes_named;
  s.attributes_named |= attributes;
  std::vector<std::string> lines = core::missing_attribute_warnings(s.scene, unnamed);
  s.warnings.insert(s.warnings.end(), lines.begin(), lines.end());
  return lines;
}

void resolve_gbuffer(GBuffer& g, const core::Scene& scene, unsigned channels, unsigned threads) {
  const size_t n = static_cast<size_t>(g.width) * g.height;
  auto plane = [&](auto& v, unsigned bit, size_t per_pixel) -> decltype(v.data()) {
    if (!(channels & bit)) {
      v.clear();
      return nullptr;
    }
    v.resize(per_pixel * n);
    return v.data();
  };
  core::ResolvedPlanes out;
  out.shading_normal = plane(g.shading_normal, kShadingNormal, 3);
  out.texcoord[0] = plane(g.texcoord, kTexcoord, 2);
  out.texcoord[1] = plane(g.texcoord1, kTexcoord1, 2);
  out.position = plane(g.position, kPosition, 3);
  out.object_position = plane(g.object_position, kObjectPosition, 3);
  out.material = plane(g.material_id, kMaterialId, 1);
  if (channels & kResolvedChannels) {
    core::HitPlanes in;
    in.pixels = n;
    in.instance = g.instance_id.data();
    in.primitive = g.primitive_id.data();
    in.barycentrics = g.uv.data();
    in.normal = g.normal.empty() ? nullptr : g.normal.data();
    core::resolve(scene, in, out, threads);
  }
  auto drop = [&](auto& v, unsigned bit) {
    if (!(channels & bit)) {
      v.clear();
      v.shrink_to_fit();
    }
  };
  drop(g.depth, kDepth);
  drop(g.normal, kNormal);
  drop(g.uv, kUv);
  drop(g.instance_id, kInstanceId);
  drop(g.primitive_id, kPrimitiveId);
  g.channels = channels;
}

}  // namespace rayfold::detail
