#include "api/resolve_gbuffer.h"

#include "output/channels.h"
#include "resolve/resolve.h"
#include "util/errors.h"

namespace rayfold::detail {

static_assert(kDefaultMaterial == core::kDefaultMaterial, "one default material id");

unsigned attributes_for(unsigned channels) {
  // The resolve's own account of what its planes read, with a stand-in plane per channel.
  core::ResolvedPlanes asked;
  float f = 0.0f;
  uint32_t id = 0;
  if (channels & kShadingNormal) asked.shading_normal = &f;
  if (channels & kTexcoord) asked.texcoord[0] = &f;
  if (channels & kTexcoord1) asked.texcoord[1] = &f;
  if (channels & kMaterialId) asked.material = &id;
  if (channels & kBaseColor) asked.base_color = &f;
  if (channels & kMetallicRoughness) asked.metallic_roughness = &f;
  if (channels & kEmissive) asked.emissive = &f;
  if (channels & kLabel) asked.label = &id;
  if (channels & kTangent) asked.tangent = &f;
  if (channels & kMappedNormal) asked.mapped_normal = &f;
  return core::attributes_read(asked);
}

unsigned trace_channels(unsigned channels) {
  unsigned trace = channels & kAllChannels;
  if (channels & kResolvedChannels) trace |= kInstanceId | kPrimitiveId | kBarycentrics;
  if (channels & (kShadingNormal | kTangent | kMappedNormal)) trace |= kNormal;  // the flat stand-in
  return trace;
}

void adopt_attributes(core::Scene& scene, core::Scene&& posed, unsigned attributes) {
  // The file's meshes come first (add_mesh appends), posed as they are.
  RF_CHECK_LE(posed.meshes.size(), scene.meshes.size(), "the file posed again has more meshes");
  for (size_t m = 0; m < posed.meshes.size(); ++m) {
    RF_CHECK_EQ(posed.meshes[m].positions.size(), scene.meshes[m].positions.size(),
                "the file posed again has another mesh");
    scene.meshes[m].attributes = std::move(posed.meshes[m].attributes);
  }
  scene.materials = std::move(posed.materials);
  scene.images = std::move(posed.images);
  if (attributes & core::kAttributeLabel) {
    RF_CHECK_LE(posed.instances.size(), scene.instances.size(), "the file posed again has more instances");
    for (size_t i = 0; i < posed.instances.size(); ++i) scene.instances[i].label = posed.instances[i].label;
    scene.labels = std::move(posed.labels);
  }
}

std::vector<std::string> load_attributes(SceneState& s, unsigned channels) {
  const unsigned attributes = attributes_for(channels);
  if (attributes == 0) return {};
  std::vector<std::string> lines;
  if (s.file && (s.file->attributes() & attributes) != attributes) {
    // A read that fails (a missing image) leaves the file as it was, so
    // that the next render asking tries again and fails the same way.
    const unsigned before = s.file->attributes();
    s.file->set_attributes(before | attributes);
    std::pair<core::Scene, std::vector<std::string>> posed;
    try {
      posed = pose_file(*s.file, s.time);
    } catch (...) {
      s.file->set_attributes(before);
      throw;
    }
    adopt_attributes(s.scene, std::move(posed.first), attributes);
    lines = std::move(posed.second);  // what the read found new (an image decoded now)
  }
  // A texture coordinate set the material channels read but no texcoord
  // channel asked for is named by their own warning (the textures').
  unsigned warned = attributes;
  if (!(channels & kTexcoord)) warned &= ~core::kAttributeTexcoord0;
  if (!(channels & kTexcoord1)) warned &= ~core::kAttributeTexcoord1;
  const unsigned unnamed = warned & ~s.attributes_named;
  s.attributes_named |= warned;
  const std::vector<std::string> missing = core::missing_attribute_warnings(s.scene, unnamed);
  lines.insert(lines.end(), missing.begin(), missing.end());
  s.warnings.insert(s.warnings.end(), lines.begin(), lines.end());
  return lines;
}

void resolve_gbuffer(GBuffer& g, const core::Scene& scene, const core::Camera& camera, unsigned channels,
                     unsigned threads) {
  const size_t n = static_cast<size_t>(g.width) * g.height;
  // A plane not asked for is left to keep_planes to free.
  auto plane = [&](auto& v, unsigned bit, size_t per_pixel) -> decltype(v.data()) {
    if (!(channels & bit)) return nullptr;
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
  out.base_color = plane(g.base_color, kBaseColor, 4);
  out.metallic_roughness = plane(g.metallic_roughness, kMetallicRoughness, 2);
  out.emissive = plane(g.emissive, kEmissive, 3);
  out.label = plane(g.label, kLabel, 1);
  out.tangent = plane(g.tangent, kTangent, 4);
  out.mapped_normal = plane(g.mapped_normal, kMappedNormal, 3);
  if (channels & kResolvedChannels) {
    core::HitPlanes in;
    in.pixels = n;
    in.instance = g.instance_id.data();
    in.primitive = g.primitive_id.data();
    in.barycentrics = g.uv.data();
    in.normal = g.normal.empty() ? nullptr : g.normal.data();
    core::resolve(scene, in, core::ray_cone(camera), out, threads);
  }
  keep_planes(g, channels);
}

void keep_planes(GBuffer& g, unsigned channels) {
  for (const core::PlaneSpec& spec : core::plane_specs()) {
    if (channels & spec.bit) continue;
    auto drop = [](auto& v) {
      v.clear();
      v.shrink_to_fit();
    };
    if (spec.floats) drop(g.*spec.floats);
    if (spec.ids) drop(g.*spec.ids);
  }
  g.channels = channels;
}

}  // namespace rayfold::detail
