// The tile history (server/replication/tile_history.h): samples at a version rebuilt, the rects
// changed since a version.
#include "tests/server/core_harness.h"

namespace loam::server {
namespace {

using namespace std::chrono_literals;
using core_test::CoreHarness;
using core_test::encoding_of;
using core_test::Received;

TEST(TileHistory, SamplesAtAVersionAreRebuiltByUndoingEveryLaterChange) {
  WorldParams p;
  p.tiles_x = 3;
  p.tiles_y = 2;
  World world(p, 20000);
  TileHistory history(64, 64);
  std::map<uint64_t, World> at;  // the world after each stamp
  at.emplace(0, world);
  StampParams s;
  s.kind = StampKind::kCrater;
  s.radius = 40;
  s.intensity = 3;
  s.shape = 0.3;
  for (uint64_t seq = 1; seq <= 8; ++seq) {
    // Around the corner of four tiles and along the world's edge.
    s.center_x = seq % 2 ? 256.0 + 9.0 * double(seq) : 760.0;
    s.center_y = seq % 2 ? 250.0 : 20.0 * double(seq);
    auto q = validate_stamp(s, p, {});
    ASSERT_TRUE(q.ok());
    auto reach = stamp_reach(*q, p);
    ASSERT_TRUE(reach.ok());
    const auto before = read_reach(world, Layer::kCoarse, *reach, 1u << 24);
    ASSERT_FALSE(before.empty());
    ASSERT_TRUE(apply_stamp(world, *q).ok());
    history.record(world.commit(seq), before);
    at.emplace(seq, world);
  }
  size_t checked = 0;
  for (int32_t m = 0; m < p.mip_count(); ++m) {
    const RectI tiles = p.tile_range(m);
    for (int32_t ty = int32_t(tiles.y0); ty < tiles.y1; ++ty) {
      for (int32_t tx = int32_t(tiles.x0); tx < tiles.x1; ++tx) {
        const TileCoord c{Layer::kCoarse, uint8_t(m), tx, ty};
        for (const auto& [held, old] : at) {
          if (old.tile_state(c).version != held) continue;  // not a version this tile had
          const auto rect = history.changed_since(c, held);
          if (!rect || rect->empty()) continue;
          const auto now = copy_tile_rect(world.coarse_tile(m, tx, ty), *rect);
          const auto rebuilt = history.samples_at<CoarseLayer>(c, held, *rect, now);
          ASSERT_TRUE(rebuilt.has_value()) << to_string(c) << " at " << held;
          EXPECT_EQ(*rebuilt, copy_tile_rect(old.coarse_tile(m, tx, ty), *rect))
              << to_string(c) << " at " << held;
          ++checked;
        }
      }
    }
  }
  EXPECT_GT(checked, 20u);
  // Over its byte bound the history forgets the least recently changed tiles: no samples,
  // no rect, and the client gets the whole tile.
  TileHistory small(64, 64, 1024);
  WorldParams one;
  World w1(one, 100);
  s.center_x = s.center_y = 128;
  auto q = validate_stamp(s, one, {});
  ASSERT_TRUE(q.ok());
  const auto before = read_reach(w1, Layer::kCoarse, *stamp_reach(*q, one), 1u << 24);
  ASSERT_TRUE(apply_stamp(w1, *q).ok());
  small.record(w1.commit(1), before);
  EXPECT_LE(small.bytes(), 1024u);
  EXPECT_EQ(small.samples_at<CoarseLayer>(TileCoord{}, 0, RectI{0, 0, 1, 1}, std::vector<uint16_t>{100}),
            std::nullopt);
}

TEST(TileHistory, ChangedSinceUnitesTheRectsAfterTheHeldVersionOrSaysUnknown) {
  TileHistory history(3, 2);
  const TileCoord a{Layer::kCoarse, 0, 0, 0}, b{Layer::kCoarse, 0, 1, 0}, c{Layer::kCoarse, 0, 2, 0};
  const std::vector<TileChange> changes = {{a, {0, 0, 4, 4}, 0, 3},
                                           {a, {10, 10, 12, 12}, 3, 7},
                                           {a, {2, 2, 3, 3}, 7, 9},
                                           {a, {50, 50, 51, 51}, 9, 11}};
  history.record(changes);
  EXPECT_EQ(history.changed_since(a, 11), RectI{});               // current
  EXPECT_EQ(history.changed_since(a, 7), (RectI{2, 2, 51, 51}));  // two changes since
  EXPECT_EQ(history.changed_since(a, 3), (RectI{2, 2, 51, 51}));  // three (the oldest kept)
  EXPECT_EQ(history.changed_since(a, 0), std::nullopt);           // beyond what is kept
  EXPECT_EQ(history.changed_since(b, 0), std::nullopt);           // never changed here
  const std::vector<TileChange> more = {{b, {0, 0, 1, 1}, 0, 12}, {c, {0, 0, 1, 1}, 0, 13}};
  history.record(more);  // two tiles at most: a, the least recently changed, goes
  EXPECT_EQ(history.changed_since(a, 9), std::nullopt);
  EXPECT_EQ(history.changed_since(c, 0), (RectI{0, 0, 1, 1}));
}

}  // namespace
}  // namespace loam::server
