// Checks shared by the public API's suites.
#pragma once

#include <gtest/gtest.h>

#include "rayfold/rayfold.h"

namespace rayfold::testing {

// The CPU reference's render of `camera` unfolded, after checking that the
// CPU reference and OpenCL give its every plane bit for bit in every fold.
inline GBuffer same_bits_on_every_backend_and_fold(const Scene& scene, const Camera& camera, unsigned channels) {
  RendererOptions cpu;
  cpu.backend = Backend::cpu;
  Renderer reference(scene, cpu), opencl(scene);
  GBuffer want = reference.render(camera, Fold::none, channels);
  for (Fold fold : {Fold::none, Fold::y, Fold::x, Fold::xy})
    for (Renderer* r : {&reference, &opencl})
      EXPECT_EQ(count_differing_pixels(r->render(camera, fold, channels), want), 0u)
          << (r == &opencl ? "opencl" : "cpu") << " fold " << fold_name(fold);
  return want;
}

}  // namespace rayfold::testing
