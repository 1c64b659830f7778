// rayfold: exact primary-visibility G-buffers (depth, normal, barycentrics,
// instance and primitive ids) by affine-transformed ray alignment.
//
//   rayfold::Scene scene = rayfold::Scene::load("scene.glb");
//   rayfold::Renderer renderer(scene);
//   rayfold::GBuffer g = renderer.render(scene.default_camera(1280, 720), rayfold::Fold::xy);
#pragma once

#include "rayfold/camera.h"
#include "rayfold/errors.h"
#include "rayfold/exr.h"
#include "rayfold/gbuffer.h"
#include "rayfold/reference.h"
#include "rayfold/renderer.h"
#include "rayfold/scene.h"
#include "rayfold/types.h"
#include "rayfold/version.h"
