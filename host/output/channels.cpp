#include "output/channels.h"

#include <algorithm>

#include "util/errors.h"

namespace rayfold::core {

const std::vector<PlaneSpec>& plane_specs() {
  // EXR names: Z, N, InstanceID and PrimitiveID as Nuke and Blender read
  // them (N here the geometric normal, as rayfold always wrote it); U, V
  // the barycentrics (the name rayfold always wrote); RenderMan's Ns for the
  // shading normal, P and Pref for world and object position; Blender's
  // Emission; TexCoord, MaterialID, BaseColor, MetallicRoughness and Label
  // say what they hold.
  static const std::vector<PlaneSpec> kSpecs = {
      {kDepth, "depth", "t", "Z", 1, {"Z"}, &GBuffer::depth, nullptr},
      {kNormal, "normal", nullptr, "N", 3, {"N.X", "N.Y", "N.Z"}, &GBuffer::normal, nullptr},
      {kBarycentrics, "barycentrics", "uv", "UV", 2, {"U", "V"}, &GBuffer::uv, nullptr},
      {kInstanceId, "instance_id", nullptr, "InstanceID", 1, {"InstanceID"}, nullptr, &GBuffer::instance_id},
      {kPrimitiveId, "primitive_id", nullptr, "PrimitiveID", 1, {"PrimitiveID"}, nullptr, &GBuffer::primitive_id},
      {kShadingNormal, "shading_normal", nullptr, "Ns", 3, {"Ns.X", "Ns.Y", "Ns.Z"}, &GBuffer::shading_normal, nullptr},
      {kTexcoord, "texcoord", nullptr, "TexCoord", 2, {"TexCoord.U", "TexCoord.V"}, &GBuffer::texcoord, nullptr},
      {kTexcoord1, "texcoord1", nullptr, "TexCoord1", 2, {"TexCoord1.U", "TexCoord1.V"}, &GBuffer::texcoord1, nullptr},
      {kPosition, "position", nullptr, "P", 3, {"P.X", "P.Y", "P.Z"}, &GBuffer::position, nullptr},
      {kObjectPosition,
       "object_position",
       nullptr,
       "Pref",
       3,
       {"Pref.X", "Pref.Y", "Pref.Z"},
       &GBuffer::object_position,
       nullptr},
      {kMaterialId, "material_id", nullptr, "MaterialID", 1, {"MaterialID"}, nullptr, &GBuffer::material_id},
      {kBaseColor,
       "base_color",
       nullptr,
       "BaseColor",
       4,
       {"BaseColor.R", "BaseColor.G", "BaseColor.B", "BaseColor.A"},
       &GBuffer::base_color,
       nullptr},
      {kMetallicRoughness,
       "metallic_roughness",
       nullptr,
       "MetallicRoughness",
       2,
       {"MetallicRoughness.Metallic", "MetallicRoughness.Roughness"},
       &GBuffer::metallic_roughness,
       nullptr},
      {kEmissive,
       "emissive",
       nullptr,
       "Emission",
       3,
       {"Emission.R", "Emission.G", "Emission.B"},
       &GBuffer::emissive,
       nullptr},
      {kLabel, "label", nullptr, "Label", 1, {"Label"}, nullptr, &GBuffer::label},
      {kFlow, "flow", nullptr, "Flow", 2, {"Flow.X", "Flow.Y"}, &GBuffer::flow, nullptr},
      {kFlowVisible, "flow_visible", nullptr, "FlowVisible", 1, {"FlowVisible"}, nullptr, &GBuffer::flow_visible},
      {kTangent,
       "tangent",
       nullptr,
       "Tangent",
       4,
       {"Tangent.X", "Tangent.Y", "Tangent.Z", "Tangent.W"},
       &GBuffer::tangent,
       nullptr},
      {kMappedNormal,
       "mapped_normal",
       nullptr,
       "MappedNormal",
       3,
       {"MappedNormal.X", "MappedNormal.Y", "MappedNormal.Z"},
       &GBuffer::mapped_normal,
       nullptr},
  };
  return kSpecs;
}

unsigned parse_channels(const std::string& list) {
  unsigned mask = 0;
  for (size_t start = 0; start <= list.size();) {
    const size_t end = std::min(list.find(',', start), list.size());
    std::string name = list.substr(start, end - start);
    name.erase(0, name.find_first_not_of(' '));
    name.erase(name.find_last_not_of(' ') + 1);
    start = end + 1;
    if (name.empty() && list.find_first_not_of(" ,") == std::string::npos) break;
    bool known = false;
    for (const PlaneSpec& p : plane_specs())
      if (name == p.name || name == p.exr_layer || (p.alias && name == p.alias)) {
        mask |= p.bit;
        known = true;
      }
    if (!known) {
      std::string names, layers;
      for (const PlaneSpec& p : plane_specs()) {
        names += std::string(names.empty() ? "" : ", ") + p.name;
        layers += std::string(layers.empty() ? "" : ", ") + p.exr_layer;
      }
      throw InputError("", "channels: unknown channel '" + name + "' (" + names + "; or as the EXR names them: " +
                               layers + "; uv is barycentrics' older name, t depth's as ray queries call it)");
    }
  }
  if (mask == 0) throw InputError("", "channels: name at least one channel");
  return mask;
}

}  // namespace rayfold::core
