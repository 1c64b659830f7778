// Writing hit info: the OpenEXR G-buffer and a PNG preview of the normals.
#pragma once

#include <string>
#include <vector>

#include "device_layout.h"

namespace rayfold::core {

// One part, channels Z, N.X, N.Y, N.Z, U, V (FLOAT), InstanceID, PrimitiveID
// (UINT). Throws InputError naming the file on failure; never leaves a
// partial file.
void write_exr(const std::string& path, const std::vector<rf_pixel_hit>& hits, int width, int height);

// Normals mapped to colour ((n + 1) / 2), misses black.
void write_png(const std::string& path, const std::vector<rf_pixel_hit>& hits, int width, int height);

// Reads back what write_exr wrote (for tests and tools); InputError on failure.
std::vector<rf_pixel_hit> read_exr(const std::string& path, int* width, int* height);

}  // namespace rayfold::core
