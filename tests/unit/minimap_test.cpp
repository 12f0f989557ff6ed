// The HUD's cache view: tile states across frames and the minimap's layout.
#include "client/terrain/minimap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "client/terrain/tile_states.h"

namespace loam::terrain {
namespace {

TileCoord tile(int32_t x, int32_t y, uint8_t mip = 0) { return {Layer::kCoarse, mip, x, y}; }

TEST(TileStates, WantedTilesArePendingUntilHeldAndStaleWhileAnEventWaitsOnThem) {
  TileStates s;
  const std::vector<TileCoord> wanted = {tile(0, 0), tile(1, 0), tile(2, 0)};
  s.update(wanted, {}, {}, 0.0);
  EXPECT_EQ(s.counts().pending, 3);
  s.update(wanted, std::vector<TileCoord>{tile(0, 0), tile(1, 0)}, std::vector<TileCoord>{tile(1, 0)}, 0.1);
  EXPECT_EQ(s.tiles().at(tile(0, 0)), TileState::kHeld);
  EXPECT_EQ(s.tiles().at(tile(1, 0)), TileState::kStale);
  EXPECT_EQ(s.tiles().at(tile(2, 0)), TileState::kPending);
}

TEST(TileStates, ATileDroppedAsTheViewMovesIsEvictedForAWhileThenForgotten) {
  TileStates s(5.0);
  const std::vector<TileCoord> both = {tile(0, 0), tile(1, 0)}, one = {tile(1, 0)};
  s.update(both, both, {}, 0.0);
  s.update(one, one, {}, 1.0);
  EXPECT_EQ(s.tiles().at(tile(0, 0)), TileState::kEvicted);
  EXPECT_EQ(s.counts().evicted, 1);
  s.update(one, one, {}, 5.9);
  EXPECT_EQ(s.tiles().at(tile(0, 0)), TileState::kEvicted);
  s.update(one, one, {}, 6.1);
  EXPECT_EQ(s.tiles().count(tile(0, 0)), 0u);
  // Wanted again: pending, not evicted; a pending tile dropped before it arrived is just gone.
  s.update(both, one, {}, 7.0);
  EXPECT_EQ(s.tiles().at(tile(0, 0)), TileState::kPending);
  s.update(one, one, {}, 8.0);
  EXPECT_EQ(s.tiles().count(tile(0, 0)), 0u);
}

MinimapInput world_with_levels() {
  MinimapInput in;
  in.world.meters_per_sample = 2.0;
  in.world.tiles_x = 8;
  in.world.tiles_y = 8;
  in.camera = scene::look_at(1024, 1024, 100, 1024, 0, 100);        // looking along -y: north
  in.level_regions = {{448, 448, 576, 576}, {384, 384, 640, 640}};  // 512 m, the outer 512 samples
  return in;
}

TEST(Minimap, TheCameraIsAtTheCentreAndTheOuterLevelSpansTheMapLessATenth) {
  const MinimapInput in = world_with_levels();
  const Minimap m = layout_minimap(in, 220.0f);
  EXPECT_FLOAT_EQ(m.frustum[0][0], 110.0f);
  EXPECT_FLOAT_EQ(m.frustum[0][1], 110.0f);
  ASSERT_EQ(m.levels.size(), 2u);
  EXPECT_NEAR(m.levels[1].x1 - m.levels[1].x0, 200.0f, 1e-3);  // 512 m of 563.2 m on 220 px
  EXPECT_NEAR(m.meters_per_pixel, 1.1 * 512.0 / 220.0, 1e-9);
  // The world (4 km) is larger than the map: its edge lies outside it on every side.
  ASSERT_TRUE(m.world.has_value());
  EXPECT_LT(m.world->x0, 0.0f);
  EXPECT_GT(m.world->x1, 220.0f);
}

TEST(Minimap, TheFrustumPointsWhereTheCameraLooksAndOpensWithItsLens) {
  MinimapInput in = world_with_levels();
  const Minimap north = layout_minimap(in, 200.0f);
  // Looking north (-y): both far corners above the camera on the map, symmetric about it.
  EXPECT_LT(north.frustum[1][1], north.frustum[0][1]);
  EXPECT_LT(north.frustum[2][1], north.frustum[0][1]);
  EXPECT_NEAR(north.frustum[1][1], north.frustum[2][1], 1e-3);
  EXPECT_NEAR(north.frustum[1][0] - 100.0f, 100.0f - north.frustum[2][0], 1e-3);
  const double half_angle = std::atan2(std::abs(north.frustum[1][0] - north.frustum[2][0]) / 2,
                                       north.frustum[0][1] - north.frustum[1][1]);
  const double expect = std::atan(std::tan(30.0 * std::numbers::pi / 180.0) * in.aspect);
  EXPECT_NEAR(half_angle, expect, 1e-4);
  // Nearly straight down: the little horizontal part of the view still gives the heading.
  in.camera = scene::look_at(1024, 1024, 500, 1024, 1024.5, 0);
  const Minimap down = layout_minimap(in, 200.0f);
  EXPECT_GT(down.frustum[1][1], down.frustum[0][1]);
}

TEST(Minimap, TilesAreColouredByStateCoarsestFirstAndClippedToTheMap) {
  MinimapInput in = world_with_levels();
  TileStates s;
  // The map spans 742.4 .. 1305.6 m each way. Mip 1 (0, 0): 0 .. 1024 m; mip 0 (1, 1): 512 ..
  // 1024 m; (2, 2): 1024 .. 1536 m; (3, 2) starts at 1536 m, off the map.
  const std::vector<TileCoord> wanted = {tile(0, 0, 1), tile(1, 1), tile(2, 2), tile(3, 2)};
  s.update(wanted, std::vector<TileCoord>{tile(0, 0, 1), tile(2, 2)}, {}, 0.0);
  in.tiles = &s.tiles();
  const Minimap m = layout_minimap(in, 220.0f);
  ASSERT_EQ(m.coarse_tiles.size(), 3u);
  EXPECT_EQ(m.coarse_tiles[0].colour, tile_state_colour(TileState::kHeld));  // mip 1, drawn first
  EXPECT_FLOAT_EQ(m.coarse_tiles[0].x0, 0.0f);
  EXPECT_FLOAT_EQ(m.coarse_tiles[0].x1, 110.0f);
  EXPECT_EQ(m.coarse_tiles[1].colour, tile_state_colour(TileState::kPending));
  EXPECT_FLOAT_EQ(m.coarse_tiles[1].y1, 110.0f);
  EXPECT_EQ(m.coarse_tiles[2].colour, tile_state_colour(TileState::kHeld));
  EXPECT_FLOAT_EQ(m.coarse_tiles[2].x0, 110.0f);
  EXPECT_FLOAT_EQ(m.coarse_tiles[2].x1, 220.0f);
}

}  // namespace
}  // namespace loam::terrain
