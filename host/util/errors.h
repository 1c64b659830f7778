// Two error tiers (as in pbrt and Embree):
//  - user errors (bad files, bad values, a missing OpenCL device) are the
//    exceptions of rayfold/errors.h, carrying context; the tools turn them
//    into "error: ..." and an exit code;
//  - internal invariants are RF_CHECK: a failure is a rayfold bug, so it
//    prints where and aborts, in every build type.
#pragma once

#include <string>

#include "rayfold/errors.h"

namespace rayfold {

[[noreturn]] void check_failed(const char* expr, const char* file, int line, const std::string& msg);

}  // namespace rayfold

#define RF_CHECK(expr, msg)                                                 \
  do {                                                                      \
    if (!(expr)) ::rayfold::check_failed(#expr, __FILE__, __LINE__, (msg)); \
  } while (0)
