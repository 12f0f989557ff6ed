#include "protocol/tile_rect.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace loam {
namespace {

// Sample (x, y) of the test tile holds x + 1000 * y, so a copied value names where it came from.
std::vector<uint32_t> numbered_tile() {
  std::vector<uint32_t> t(static_cast<size_t>(kTileSamples));
  for (int32_t y = 0; y < kTileSize; ++y)
    for (int32_t x = 0; x < kTileSize; ++x) t[size_t(y * kTileSize + x)] = uint32_t(x + 1000 * y);
  return t;
}

TEST(TileRect, CopiesTheRectRowByRowFromARowMajorTile) {
  const std::vector<uint32_t> tile = numbered_tile();
  const std::vector<uint32_t> got = copy_tile_rect(std::span<const uint32_t>(tile), RectI{3, 250, 6, 252});
  EXPECT_EQ(got, (std::vector<uint32_t>{250003, 250004, 250005, 251003, 251004, 251005}));
}

TEST(TileRect, TheWholeTileIsTheTileItself) {
  const std::vector<uint32_t> tile = numbered_tile();
  EXPECT_EQ(copy_tile_rect(std::span<const uint32_t>(tile), RectI{0, 0, kTileSize, kTileSize}), tile);
}

// World::detail_tile is an empty span where the detail tile is all zero.
TEST(TileRect, AnUnstoredTileReadsAsZeros) {
  const std::vector<int8_t> got = copy_tile_rect(std::span<const int8_t>(), RectI{10, 20, 14, 22});
  EXPECT_EQ(got, std::vector<int8_t>(8, 0));
}

TEST(TileRect, ARectReachingOutsideTheTileOrAWrongSizedTileGivesNothing) {
  const std::vector<uint16_t> tile(size_t(kTileSamples), 7);
  EXPECT_TRUE(copy_tile_rect(std::span<const uint16_t>(tile), RectI{250, 0, 257, 1}).empty());
  EXPECT_TRUE(copy_tile_rect(std::span<const uint16_t>(tile), RectI{-1, 0, 2, 1}).empty());
  const std::vector<uint16_t> short_tile(100, 7);
  EXPECT_TRUE(copy_tile_rect(std::span<const uint16_t>(short_tile), RectI{0, 0, 2, 2}).empty());
}

}  // namespace
}  // namespace loam
