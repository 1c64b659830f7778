// The speed/accuracy benchmark's rows are real: Embree (when built in) finds
// nearly the double reference's triangles with the very same rays, and the
// fold modes of each rayfold variant report the same accuracy.
#include <gtest/gtest.h>

#include "../tools/embree_peer.h"
#include "../tools/peers.h"

namespace rayfold {
namespace {

TEST(Peers, EveryVariantIsMeasured) {
  PeerOptions opt;
  opt.scene = std::string(RAYFOLD_SOURCE_DIR) + "/scenes/atrium.glb";
  opt.width = 96;
  opt.height = 54;
  opt.views = 2;
  opt.frames = 1;
  opt.warmup = 0;
  const PeerReport r = run_peers(opt);
  ASSERT_EQ(r.rows.size(), EmbreePeer::available() ? 14u : 12u);
  if (!EmbreePeer::available()) {
    EXPECT_FALSE(r.embree_note.empty());
  }
  for (const PeerRow& row : r.rows) {
    EXPECT_GT(row.ms, 0.0) << row.variant << " " << row.fold;
    EXPECT_GT(row.accuracy.same_hit, 0.99) << row.variant << " " << row.fold;
    EXPECT_LT(row.accuracy.depth_median, 1e-5) << row.variant << " " << row.fold;
  }
  // The exact variants give identical bits in every fold mode: identical accuracy.
  for (size_t i = 1; i < 4; ++i) EXPECT_EQ(r.rows[i].accuracy.same_hit, r.rows[0].accuracy.same_hit);
  for (size_t i = 9; i < 12; ++i) EXPECT_EQ(r.rows[i].accuracy.same_hit, r.rows[0].accuracy.same_hit);
  EXPECT_NE(peers_markdown(r).find("| OpenCL exact | xy |"), std::string::npos);
}

}  // namespace
}  // namespace rayfold
