// The public G-buffer's resolved channels (kShadingNormal and after): which
// visibility channels and scene attributes they need, the attributes read
// from the file on first need, and the resolve (resolve/resolve.h) into a
// GBuffer's planes.
#pragma once

#include <string>
#include <vector>

#include "api/scene_state.h"
#include "rayfold/gbuffer.h"

namespace rayfold::detail {

constexpr unsigned kResolvedChannels = kAnyChannel & ~static_cast<unsigned>(kAllChannels);

// The scene attributes (core::Attribute bits) the channels read.
unsigned attributes_for(unsigned channels);
// The channels the trace fills for these: those asked for, and the ids,
// barycentrics and geometric normal the resolved ones are made from.
unsigned trace_channels(unsigned channels);

// Moves what the file posed again (`posed`, read with these Attribute bits)
// holds of attributes, materials, images and labels into `scene`, whose
// first meshes and instances are the file's.
void adopt_attributes(core::Scene& scene, core::Scene&& posed, unsigned attributes);

// Reads the attributes `channels` read (attributes_for) that the scene
// lacks from its file (posed as it is now), once; returns one line for each
// mesh that lacks one of them and was not named before, and what the file's
// reading said that it had not said before (a 16-bit image decoded at 8
// bits), also added to the scene's warnings.
std::vector<std::string> load_attributes(SceneState& s, unsigned channels);

// Fills g's resolved planes that `channels` asks for from its visibility
// planes, then keep_planes(g, channels).
// `camera` is the view's (the material channels' ray cones).
void resolve_gbuffer(GBuffer& g, const core::Scene& scene, const core::Camera& camera, unsigned channels,
                     unsigned threads);

// Frees every plane of g that `channels` does not name and sets g.channels
// to it.
void keep_planes(GBuffer& g, unsigned channels);

}  // namespace rayfold::detail
