// Which tiles a clipmap viewer subscribes to (client/lod/clipmap_interest.h): every tile a
// level reads is in the set, the coarsest mip always is, and a camera moving back and forth
// over a tile border keeps its subscriptions (hysteresis) while a far move drops the old ones.
#include "client/lod/clipmap_interest.h"

#include <gtest/gtest.h>

#include <set>
#include <vector>

#include "client/lod/clipmap_mesh.h"

namespace loam::lod {
namespace {

WorldParams big_world() {
  WorldParams p;
  p.meters_per_sample = 1.0;
  p.origin_tile_x = -20;
  p.origin_tile_y = -12;
  p.tiles_x = 40;
  p.tiles_y = 30;
  return p;
}

InterestConfig config() {
  InterestConfig c;
  c.n = 63;
  c.levels = 5;
  c.margin = 16;
  c.mip0_radius_m = 100;
  c.detail_radius_m = 20;
  return c;
}

TEST(ClipmapInterest, TilesCoverEveryLevelsRegionAndTheCoarsestMip) {
  const WorldParams w = big_world();
  const InterestConfig c = config();
  const double cx = 1234.5, cy = -700.25;
  const std::set<TileCoord> tiles = clipmap_tiles(w, c, cx, cy, 0);
  const int32_t mips = w.mip_count();
  for (const LevelPlacement& lp : place_levels(c.n, c.levels, cx, cy)) {
    const int32_t m = std::min(lp.level, mips - 1);
    const int64_t s = lp.spacing();
    // Every sample the level's texture holds, in its mip's grid.
    for (int64_t j = -c.pad; j < c.n + c.pad; j += 7) {
      for (int64_t i = -c.pad; i < c.n + c.pad; i += 7) {
        const int64_t x0 = lp.origin_x + i * s, y0 = lp.origin_y + j * s;
        const int64_t xm = floor_div(x0, int64_t(1) << m), ym = floor_div(y0, int64_t(1) << m);
        const TileCoord t{Layer::kCoarse, uint8_t(m), int32_t(floor_div(xm, kTileSize)),
                          int32_t(floor_div(ym, kTileSize))};
        if (!w.tile_range(m).contains(t.tx, t.ty)) continue;
        EXPECT_TRUE(tiles.count(t)) << "level " << lp.level << " misses " << to_string(t);
      }
    }
  }
  const RectI top = w.tile_range(mips - 1);
  EXPECT_TRUE(tiles.count({Layer::kCoarse, uint8_t(mips - 1), int32_t(top.x0), int32_t(top.y0)}));
  EXPECT_TRUE(tiles.count(
      {Layer::kCoarse, 0, int32_t(floor_div(1234, kTileSize)), int32_t(floor_div(-701, kTileSize))}));
  bool detail = false;
  for (const TileCoord& t : tiles) {
    detail = detail || t.layer == Layer::kDetail;
    if (t.layer == Layer::kCoarse) {
      EXPECT_TRUE(w.tile_range(t.mip).contains(t.tx, t.ty)) << to_string(t);
    }
  }
  EXPECT_TRUE(detail);
}

TEST(ClipmapInterest, CameraMovingBackAndForthOverATileBorderKeepsItsTiles) {
  ClipmapInterest interest(big_world(), config());
  const auto first = interest.update(255.0, 10.0);
  EXPECT_FALSE(first.subscribe.empty());
  EXPECT_TRUE(first.unsubscribe.empty());
  interest.update(258.0, 10.0);
  for (int i = 0; i < 10; ++i) {
    const auto d = interest.update(i % 2 ? 258.0 : 255.0, 10.0);
    EXPECT_TRUE(d.empty()) << "step " << i << ": " << d.subscribe.size() << " in, " << d.unsubscribe.size()
                           << " out";
  }
}

TEST(ClipmapInterest, FarMoveDropsTheTilesLeftBehind) {
  const WorldParams w = big_world();
  ClipmapInterest interest(w, config());
  interest.update(-4000.0, -2500.0);
  const auto d = interest.update(4000.0, 3000.0);
  EXPECT_FALSE(d.unsubscribe.empty());
  EXPECT_FALSE(d.subscribe.empty());
  const std::set<TileCoord> keep = clipmap_tiles(w, config(), 4000.0, 3000.0, 2 * config().margin);
  for (const TileCoord& t : interest.subscribed()) EXPECT_TRUE(keep.count(t)) << to_string(t);
  // What stayed subscribed is only what the new view still reads (the coarse mips).
  for (const TileCoord& t : d.unsubscribe) EXPECT_FALSE(interest.subscribed().count(t));
}

TEST(ClipmapInterest, GivenRegionsAreHeldAtEachLevelsMipAndFollowedWithHysteresis) {
  const WorldParams w = big_world();
  InterestConfig c = config();
  c.mip0_radius_m = 0;
  c.detail_radius_m = 0;
  // An error-driven clipmap's regions: 600 level samples a side, level 6 past the coarsest mip.
  auto regions_at = [](int64_t x, int64_t y) {
    std::vector<RectI> r;
    for (int32_t l = 0; l < 7; ++l)
      r.push_back({(x >> l) - 300, (y >> l) - 300, (x >> l) + 300, (y >> l) + 300});
    return r;
  };
  const std::vector<RectI> regions = regions_at(1000, -500);
  const std::set<TileCoord> tiles = region_tiles(w, c, regions, 1000, -500, 0);
  const int32_t mips = w.mip_count();
  for (int32_t l = 0; l < 7; ++l) {
    const int32_t m = std::min(l, mips - 1);
    const int64_t up = int64_t(1) << (l - m);
    const RectI& r = regions[size_t(l)];
    const RectI need =
        tiles_overlapping({r.x0 * up, r.y0 * up, r.x1 * up, r.y1 * up}).intersect(w.tile_range(m));
    ASSERT_FALSE(need.empty());
    for (int64_t ty = need.y0; ty < need.y1; ++ty)
      for (int64_t tx = need.x0; tx < need.x1; ++tx)
        EXPECT_TRUE(tiles.count({Layer::kCoarse, uint8_t(m), int32_t(tx), int32_t(ty)}))
            << l << ": " << tx << "," << ty;
  }
  for (const TileCoord& t : tiles) EXPECT_TRUE(w.tile_range(t.mip).contains(t.tx, t.ty)) << to_string(t);
  // A few samples back and forth: nothing is dropped or added again.
  ClipmapInterest interest(w, c);
  const auto first = interest.update(1000, -500, regions);
  EXPECT_EQ(first.subscribe.size(), interest.subscribed().size());
  const auto there = interest.update(1004, -500, regions_at(1004, -500));
  const auto back = interest.update(1000, -500, regions);
  EXPECT_TRUE(back.unsubscribe.empty());
  EXPECT_TRUE(there.unsubscribe.empty());
  // Far away: the tiles left behind go, the coarsest mip stays.
  const auto far = interest.update(-15000, 9000, regions_at(-15000, 9000));
  EXPECT_FALSE(far.unsubscribe.empty());
  for (const TileCoord& t : far.unsubscribe) EXPECT_NE(int32_t(t.mip), mips - 1);
}
}  // namespace
}  // namespace loam::lod
