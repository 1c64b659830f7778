// Internal checks (util/errors.h): a failed comparison names both sides and
// their values; RF_DCHECK is checked in debug builds only.
#include <gtest/gtest.h>

#include <cstddef>

#include "util/errors.h"

namespace {

TEST(Checks, AFailedComparisonPrintsBothValues) {
  const size_t hits = 6, pixels = 8;
  EXPECT_DEATH(RF_CHECK_EQ(hits, pixels, "hits of another size"),
               "check 'hits == pixels \\(values: 6 vs 8\\)' failed: hits of another size");
  EXPECT_DEATH(RF_CHECK_LT(pixels, hits, "order"), "pixels < hits \\(values: 8 vs 6\\)");
  EXPECT_DEATH(RF_CHECK_GE(-1, 0, "sign"), "-1 >= 0 \\(values: -1 vs 0\\)");
}

TEST(Checks, PassingChecksEvaluateEachSideOnce) {
  int calls = 0;
  const auto next = [&] { return ++calls; };
  RF_CHECK_EQ(next(), 1, "first call");
  RF_CHECK_LE(next(), 2, "second call");
  RF_CHECK_NE(next(), 0, "third call");
  RF_CHECK_GT(next(), 3, "fourth call");
  EXPECT_EQ(calls, 4);
}

TEST(Checks, DebugChecksOnlyInDebugBuilds) {
  int evaluated = 0;
  RF_DCHECK(++evaluated > 0, "counted");
#ifdef NDEBUG
  EXPECT_EQ(evaluated, 0);  // compiled, not run
  RF_DCHECK(false, "a release build does not check");
#else
  EXPECT_EQ(evaluated, 1);
  EXPECT_DEATH(RF_DCHECK(false, "debug"), "check 'false' failed: debug");
#endif
}

}  // namespace
