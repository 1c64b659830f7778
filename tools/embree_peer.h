// Embree 3 as the peer in the speed/accuracy benchmark: the same scene as
// instances of per-mesh scenes, traced with the very same camera-space float
// rays rayfold generates (origin at the eye, instance transforms
// camera_from_object), with rtcIntersect1 and with coherent rtcIntersect16
// packets of 4x4 pixels. Built only when Embree is installed.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "../host/camera.h"
#include "../host/frame.h"
#include "../host/scene.h"

namespace rayfold {

class EmbreePeer {
 public:
  // False when rayfold was built without Embree; the peer then says so.
  static bool available();

  EmbreePeer(const Scene& scene, const SceneData& data, unsigned threads);
  ~EmbreePeer();

  // Moves the instances to this camera's space and rebuilds the top level.
  void set_camera(const Camera& camera);
  // Every pixel's hit (distance, instance, primitive; normals and
  // barycentrics are left 0). Returns ms.
  double trace1(std::vector<rf_pixel_hit>& hits);
  double trace16(std::vector<rf_pixel_hit>& hits);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rayfold
