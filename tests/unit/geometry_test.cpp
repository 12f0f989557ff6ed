#include "protocol/geometry.h"

#include <gtest/gtest.h>

namespace loam {
namespace {

TEST(Geometry, FloorDivisionRoundsTowardNegativeInfinity) {
  EXPECT_EQ(floor_div(-1, 256), -1);
  EXPECT_EQ(floor_div(-256, 256), -1);
  EXPECT_EQ(floor_div(-257, 256), -2);
  EXPECT_EQ(floor_div(255, 256), 0);
  EXPECT_EQ(floor_mod(-1, 256), 255);
  EXPECT_EQ(ceil_div(-1, 256), 0);
  EXPECT_EQ(ceil_div(257, 256), 2);
}

TEST(Geometry, TilesOverlappingNegativeSamplesUseFloorNotTruncation) {
  // Samples -1 and 0 belong to tiles -1 and 0: truncating division would put both in tile 0.
  const RectI t = tiles_overlapping({-1, -257, 1, -256});
  EXPECT_EQ(t, (RectI{-1, -2, 1, -1}));
  EXPECT_EQ(tile_rect(-1, -2), (RectI{-256, -512, 0, -256}));
}

TEST(Geometry, MipTileRangeCoversWorldWithNegativeUnalignedOrigin) {
  WorldParams p;
  p.origin_tile_x = -3;
  p.origin_tile_y = 5;
  p.tiles_x = 5;  // samples [-768, 512)
  p.tiles_y = 2;  // samples [1280, 1792)
  ASSERT_TRUE(p.validate().ok());
  EXPECT_EQ(p.tile_range(0), (RectI{-3, 5, 2, 7}));
  // mip 1 tiles span 512 samples: [-768, 512) -> tiles -2..0; [1280, 1792) -> tiles 2..3
  EXPECT_EQ(p.tile_range(1), (RectI{-2, 2, 1, 4}));
  const int32_t mips = p.mip_count();
  const RectI top = p.tile_range(mips - 1);
  EXPECT_LE(top.width(), 2) << "an unaligned world straddles at most 2 x 2 top tiles";
  EXPECT_LE(top.height(), 2);
  EXPECT_EQ(mips, 4) << "5 tiles wide: spans of 1, 2, 4, 8 tiles";
  WorldParams aligned = p;
  aligned.origin_tile_x = 8;
  aligned.origin_tile_y = -16;
  EXPECT_EQ(aligned.tile_range(aligned.mip_count() - 1).area(), 1) << "an aligned world has one top tile";
  EXPECT_GT(p.tile_range(mips - 2).area(), 1) << "no redundant extra mip";
}

TEST(Geometry, WorldParamsRejectEachBadFieldByName) {
  auto expect_field = [](WorldParams p, const char* field) {
    const Status st = p.validate();
    ASSERT_FALSE(st.ok()) << field;
    EXPECT_EQ(st.error().field, field);
  };
  WorldParams p;
  p.meters_per_sample = 0;
  expect_field(p, "meters_per_sample");
  p = {};
  p.meters_per_sample = std::numeric_limits<double>::quiet_NaN();
  expect_field(p, "meters_per_sample");
  p = {};
  p.meters_per_unit = -1;
  expect_field(p, "meters_per_unit");
  p = {};
  p.detail_factor = 3;
  expect_field(p, "detail_factor");
  p = {};
  p.tiles_x = 0;
  expect_field(p, "tiles_x");
  p = {};
  p.origin_tile_y = 1 << 30;
  expect_field(p, "origin_tile_y");
  p = {};
  p.height_offset = std::numeric_limits<double>::infinity();
  expect_field(p, "height_offset");
}

TEST(Geometry, QuantizeHeightSaturatesAndRoundsToNearest) {
  WorldParams p;
  p.height_offset = -10;
  p.meters_per_unit = 0.5;
  EXPECT_EQ(quantize_height(p, -10), 0);
  EXPECT_EQ(quantize_height(p, -1000), 0);
  EXPECT_EQ(quantize_height(p, 1e9), 65535);
  EXPECT_EQ(quantize_height(p, std::numeric_limits<double>::quiet_NaN()), 0);
  EXPECT_EQ(quantize_height(p, -9.76), 0);  // 0.48 units
  EXPECT_EQ(quantize_height(p, -9.74), 1);  // 0.52 units
}

}  // namespace
}  // namespace loam
