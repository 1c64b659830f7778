// The G-buffer of one render: its channels per pixel in planes, rows from
// the top. docs/channels.md gives every plane's meaning, space and miss value.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "rayfold/types.h"

namespace rayfold {

// How the screen is folded: y mirrors about the camera's vertical plane
// (pairs columns), x about the horizontal plane (pairs rows), xy both. The
// output is bit for bit the same in every mode; only the work differs.
enum class Fold { none, y, x, xy };

// "none", "y", "x" or "xy", as the CLI's --fold and Python's fold= spell them.
inline const char* fold_name(Fold f) {
  switch (f) {
    case Fold::y: return "y";
    case Fold::x: return "x";
    case Fold::xy: return "xy";
    default: return "none";
  }
}

// The channels a render fills, as bit flags (kAllChannels by default): a
// job that needs depth and masks asks for kDepth | kInstanceId and gets the
// other planes empty, skipping their copies. The first five are the
// visibility buffer the trace writes; the others are resolved from it and
// the scene's attributes, which the scene reads from its file on the first
// render that asks for them.
enum Channels : unsigned {
  kDepth = 1u,
  kNormal = 2u,        // the geometric normal
  kUv = 4u,            // the barycentrics (GBuffer::uv), not texture coordinates
  kBarycentrics = 4u,  // kUv's name that says what it holds
  kInstanceId = 8u,
  kPrimitiveId = 16u,
  kAllChannels = 31u,          // the visibility buffer: every channel above, the default
  kShadingNormal = 32u,        // NORMAL interpolated, in world space
  kTexcoord = 64u,             // TEXCOORD_0 interpolated
  kTexcoord1 = 128u,           // TEXCOORD_1 interpolated
  kPosition = 256u,            // world-space position
  kObjectPosition = 512u,      // position in the mesh's own space
  kMaterialId = 1024u,         // the glTF material's index
  kBaseColor = 2048u,          // linear RGBA: factor, vertex colour and texture
  kMetallicRoughness = 4096u,  // metallic, roughness
  kEmissive = 8192u,           // linear RGB
  kLabel = 16384u,             // the instance's label from its node's extras (Scene::labels)
  kFlow = 32768u,              // where the surface point is in another view, minus the pixel (FlowTo)
  kFlowVisible = 65536u,       // whether it is seen there (FlowTo)
  kFlowChannels = 98304u,      // kFlow | kFlowVisible: a render with a FlowTo only
  kTangent = 131072u,          // world-space tangent and bitangent sign (TANGENT, or MikkTSpace's)
  kMappedNormal = 262144u,     // the shading normal with the material's normalTexture applied
  kEveryChannel = 425983u,     // every channel one view's render makes (all but kFlowChannels)
  kAnyChannel = 524287u,       // every plane a GBuffer may hold
};

// A comma-separated list of channel names as Channels, as the CLI's
// --channels and Python's channels= take them: depth, normal,
// barycentrics, instance_id, primitive_id, shading_normal, texcoord,
// texcoord1, position, object_position, material_id, base_color,
// metallic_roughness, emissive, label, tangent, mapped_normal, or the EXR's
// names for them (Z, N, UV, InstanceID, PrimitiveID, Ns, TexCoord,
// TexCoord1, P, Pref, MaterialID, BaseColor, MetallicRoughness, Emission,
// Label, Tangent, MappedNormal), flow and flow_visible (Flow, FlowVisible); uv is
// barycentrics' older name. InputError naming an
// unknown name, or for none.
unsigned parse_channels(const std::string& list);

struct GBuffer;
// The pixels where any plane of two G-buffers of one size and the same
// channels differs in its bits (0: identical, every plane, every pixel).
size_t count_differing_pixels(const GBuffer& a, const GBuffer& b);

// A triangle's material_id where its primitive names no material (glTF's
// default material); kMiss on a miss.
constexpr uint32_t kDefaultMaterial = 0xFFFFFFFEu;

// What a G-buffer's depth plane holds.
enum class Depth {
  distance,  // along the pixel's ray from the eye (Camera::ray_direction)
  planar,    // along the camera's axis (camera-space -z; Nuke's and Blender's Z, a NeRF's depth map)
};

// Where a render's time went, stage by stage, in ms on the host's clock (a
// trace of several views: the whole pass's, shared by its views).
struct StageTimes {
  double cull_ms = 0.0;      // instances outside the view left out
  double tlas_ms = 0.0;      // the top-level tree over the rest
  double upload_ms = 0.0;    // its nodes and instances to the device
  double ray_list_ms = 0.0;  // the compacted ray list; 0 when the last render's still holds
  double trace_ms = 0.0;     // the kernel
  double readback_ms = 0.0;  // the hits or planes back from the device
};

// The top-level tree a render traced.
struct TopLevelStats {
  size_t scene_instances = 0;   // instances the scene renders (not hidden, not empty)
  size_t traced_instances = 0;  // in the tree, after culling: copies per view and per mirror included
  size_t out_of_range = 0;      // instances beyond the float range at this view (and in `warnings`)
  double sah_cost = 0.0;        // the tree's surface-area cost
};

struct GBuffer {
  int width = 0, height = 0;
  // Distance from the eye along the pixel's ray (Camera::ray_direction), in
  // world units; +inf on a miss. height * width.
  std::vector<float> depth;
  // World-space geometric normal, unit length, on the side the triangle's
  // winding makes its front (the file's, also under mirroring transforms);
  // 0 on a miss. height * width * 3.
  std::vector<float> normal;
  // Barycentric weights of the triangle's second and third vertex; 0 on a
  // miss. height * width * 2.
  std::vector<float> uv;
  std::vector<uint32_t> instance_id;   // Scene instance index, kMiss on a miss
  std::vector<uint32_t> primitive_id;  // triangle index within the mesh, kMiss on a miss
  // Resolved from the hit (kShadingNormal and after; 0 on a miss unless
  // said otherwise; docs/channels.md): every float computed in double from
  // the file's values and rounded once, the first vertex weighted
  // (1 - u) - v. World-space unit shading normal, the file's NORMAL through
  // the instance's inverse transpose (the geometric normal where the
  // triangle has none). height * width * 3.
  std::vector<float> shading_normal;
  std::vector<float> texcoord;         // TEXCOORD_0 as the file gives it, (0, 0) without; height * width * 2
  std::vector<float> texcoord1;        // TEXCOORD_1 likewise
  std::vector<float> position;         // world space; height * width * 3
  std::vector<float> object_position;  // the mesh's own space; height * width * 3
  std::vector<uint32_t> material_id;   // glTF material index, kDefaultMaterial for none, kMiss on a miss
  // The material at the hit, each texture sampled with its sampler at the
  // pixel's ray-cone level of detail (docs/channels.md), linear values.
  std::vector<float> base_color;          // RGBA: baseColorFactor * COLOR_0 * texture; height * width * 4
  std::vector<float> metallic_roughness;  // metallic, roughness; height * width * 2
  std::vector<float> emissive;            // RGB: emissiveFactor * texture * strength; height * width * 3
  std::vector<uint32_t> label;            // index into Scene::labels (0: no label), kMiss on a miss
  // Optical flow to another view (Renderer::render with a FlowTo): the
  // pixel's surface point (the same barycentrics on the same triangle,
  // posed at the other view's time) projected into the other image, minus
  // the pixel, in pixels, +x right, +y down (docs/channels.md); NaN where
  // it is behind the other eye, 0 on a miss. height * width * 2.
  std::vector<float> flow;
  // 1 where that point is seen in the other view (inside its image, and
  // nothing on the segment from its eye closer than 1e-4 of the segment's
  // length short of it), else 0; kMiss on a miss.
  std::vector<uint32_t> flow_visible;
  // The surface's tangent frame at the hit (docs/channels.md): the
  // tangent, world space, unit length, orthogonal to shading_normal, from
  // the file's TANGENT interpolated or, where the mesh has none, MikkTSpace's
  // tangents of the normal texture's coordinate set; then the bitangent's
  // sign w (bitangent = w * cross(shading_normal, tangent), glTF's rule,
  // a mirroring transform's sign included). height * width * 4.
  std::vector<float> tangent;
  // The shading normal with the material's normalTexture applied in that
  // frame (glTF 3.9.3, its scale on x and y), unit length; shading_normal
  // where the material has none. height * width * 3.
  std::vector<float> mapped_normal;
  unsigned channels = kAllChannels;    // the planes filled (Channels); the others are empty
  Depth depth_kind = Depth::distance;  // what `depth` measures (RendererOptions::depth)
  bool exact_depth = false;            // depth from the exact ray in double-float (RendererOptions::exact_depth)

  Fold fold = Fold::none;  // the fold traced (one the camera allows; Camera::can_fold_columns)
  size_t rays = 0;         // rays traced
  size_t hits = 0;         // pixels that hit
  double trace_ms = 0.0;   // on the device (a trace of several views: its share)
  double frame_ms = 0.0;   // culling, top-level build, upload, ray list, trace, readback (likewise)
  int views_in_trace = 1;  // views traced together with this one, itself included (Renderer::render_views)
  // The pose it shows: the scene's time when rendered (Scene::time(), or
  // render_at's), seconds; NaN for the file's rest pose or a scene without a
  // file. Written to the EXR as rayfold:time.
  double time = std::numeric_limits<double>::quiet_NaN();
  StageTimes stages;       // trace_ms's and the other stages' times (likewise the pass's)
  TopLevelStats top_level;
  // The kernel that traced it ("tile", "single", "cpu reference") and why
  // ("CPU device", "chosen", "measured on the first frame: ...").
  std::string kernel, kernel_reason;
  // What this render may have lost, in words (docs/exactness.md); empty
  // within rayfold's exact range.
  std::vector<std::string> warnings;
};

}  // namespace rayfold
