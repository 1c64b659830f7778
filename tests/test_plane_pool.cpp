// The Python module's pool of freed G-buffer planes (host/python/plane_pool.h):
// what it hands back, and that sizes nobody asks for again cannot fill it.
#include <gtest/gtest.h>

#include <vector>

#include "python/plane_pool.h"

namespace rayfold::python {
namespace {

constexpr size_t kBig = size_t{1} << 20;  // floats: 4 MB, kept

TEST(PlanePool, HandsBackTheNewestOfTheSizeAskedForWithItsMemory) {
  PlanePool pool;
  std::vector<float> a(kBig, 1.0f), b(kBig, 2.0f);
  const float* b_memory = b.data();
  pool.give(std::move(a));
  pool.give(std::move(b));
  EXPECT_TRUE(pool.take<float>(kBig + 1).empty());
  EXPECT_TRUE(pool.take<uint32_t>(kBig).empty()) << "a float plane handed out as ids";
  std::vector<float> got = pool.take<float>(kBig);
  ASSERT_EQ(got.size(), kBig);
  EXPECT_EQ(got.data(), b_memory);
  EXPECT_EQ(got[0], 2.0f);
  EXPECT_EQ(pool.take<float>(kBig).size(), kBig);
  EXPECT_TRUE(pool.take<float>(kBig).empty()) << "handed out twice";
}

TEST(PlanePool, KeepsNeitherSmallNorForeignVectors) {
  PlanePool pool;
  pool.give(std::vector<float>(100, 0.0f));           // 400 bytes: malloc reuses those itself
  pool.give(std::vector<uint8_t>(kBig, uint8_t{1}));  // not a plane's type
  pool.give(std::vector<float>());
  EXPECT_TRUE(pool.take<float>(100).empty());
  EXPECT_TRUE(pool.take<float>(0).empty());
}

// Rays of a new count each call (lidar scans) give back sizes that never
// come again: the oldest go, so a render's size is still kept afterwards.
TEST(PlanePool, SizesNobodyAsksForAgainCannotFillIt) {
  PlanePool pool;
  for (size_t k = 0; k < 100; ++k) pool.give(std::vector<uint32_t>(kBig + k, 0u));  // 400 MB in all
  const size_t frame = 1280 * 720 * 3;
  std::vector<float> normal(frame, 0.0f);
  const float* memory = normal.data();
  pool.give(std::move(normal));
  std::vector<float> got = pool.take<float>(frame);
  EXPECT_EQ(got.data(), memory) << "a full pool refused the newest plane";
  EXPECT_TRUE(pool.take<uint32_t>(kBig).empty()) << "the oldest was kept past 256 MB";
  EXPECT_EQ(pool.take<uint32_t>(kBig + 99).size(), kBig + 99) << "the newest was dropped";
  for (size_t k = 0; k < 400; ++k) pool.give(std::vector<float>(size_t{1} << 14 | k, 0.0f));  // 64 KiB each
  EXPECT_TRUE(pool.take<float>(size_t{1} << 14).empty()) << "more vectors kept than the pool's count";
  EXPECT_EQ(pool.take<float>(size_t{1} << 14 | 399).size(), size_t{1} << 14 | 399);
}

}  // namespace
}  // namespace rayfold::python
