// Two error tiers (as in pbrt and Embree):
//  - user errors (bad files, bad values, a missing OpenCL device) are the
//    exceptions of rayfold/errors.h, carrying context; the tools turn them
//    into "error: ..." and an exit code;
//  - internal invariants are RF_CHECK: a failure is a rayfold bug, so it
//    prints where and aborts, in every build type. A comparison is
//    RF_CHECK_EQ (NE, LT, LE, GT, GE), which prints both values; RF_DCHECK
//    is for hot loops, checked in debug builds only.
#pragma once

#include <sstream>
#include <string>

#include "rayfold/errors.h"

namespace rayfold {

[[noreturn]] void check_failed(const char* expr, const char* file, int line, const std::string& msg);

namespace detail {

// "a <op> b (values: A vs B)" for a failed RF_CHECK_<OP>.
template <class A, class B>
[[noreturn]] void check_op_failed(const char* a_text, const char* op, const char* b_text, const A& a, const B& b,
                                  const char* file, int line, const std::string& msg) {
  std::ostringstream s;
  s << a_text << ' ' << op << ' ' << b_text << " (values: " << a << " vs " << b << ')';
  check_failed(s.str().c_str(), file, line, msg);
}

}  // namespace detail
}  // namespace rayfold

#define RF_CHECK(expr, msg)                                                 \
  do {                                                                      \
    if (!(expr)) ::rayfold::check_failed(#expr, __FILE__, __LINE__, (msg)); \
  } while (0)

#define RF_CHECK_OP(a, op, b, msg)                                                                         \
  do {                                                                                                     \
    const auto& rf_check_a_ = (a);                                                                         \
    const auto& rf_check_b_ = (b);                                                                         \
    if (!(rf_check_a_ op rf_check_b_))                                                                     \
      ::rayfold::detail::check_op_failed(#a, #op, #b, rf_check_a_, rf_check_b_, __FILE__, __LINE__, (msg)); \
  } while (0)
#define RF_CHECK_EQ(a, b, msg) RF_CHECK_OP(a, ==, b, msg)
#define RF_CHECK_NE(a, b, msg) RF_CHECK_OP(a, !=, b, msg)
#define RF_CHECK_LT(a, b, msg) RF_CHECK_OP(a, <, b, msg)
#define RF_CHECK_LE(a, b, msg) RF_CHECK_OP(a, <=, b, msg)
#define RF_CHECK_GT(a, b, msg) RF_CHECK_OP(a, >, b, msg)
#define RF_CHECK_GE(a, b, msg) RF_CHECK_OP(a, >=, b, msg)

// Debug builds only: for checks inside loops whose cost a release build
// does not pay. The expression is still compiled (not evaluated) in release.
#ifdef NDEBUG
#define RF_DCHECK(expr, msg) \
  do {                       \
    (void)sizeof(!(expr));   \
  } while (0)
#else
#define RF_DCHECK(expr, msg) RF_CHECK(expr, msg)
#endif
