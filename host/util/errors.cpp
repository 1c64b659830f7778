#include "util/errors.h"

#include <cstdio>
#include <cstdlib>

namespace rayfold {

void check_failed(const char* expr, const char* file, int line, const std::string& msg) {
  std::fprintf(stderr, "rayfold internal error: %s:%d: check '%s' failed: %s\n", file, line, expr, msg.c_str());
  std::abort();
}

}  // namespace rayfold
