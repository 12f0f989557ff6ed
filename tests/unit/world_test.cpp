#include "protocol/world.h"

#include <gtest/gtest.h>

#include <random>

#include "protocol/tile_hash.h"

namespace loam {
namespace {

WorldParams small_params(int32_t ox = 0, int32_t oy = 0, int32_t tx = 3, int32_t ty = 2) {
  WorldParams p;
  p.origin_tile_x = ox;
  p.origin_tile_y = oy;
  p.tiles_x = tx;
  p.tiles_y = ty;
  return p;
}

World random_world(const WorldParams& p, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<uint16_t> s(size_t(p.sample_rect().area()));
  for (auto& v : s) v = uint16_t(rng());
  auto w = World::from_samples(p, s);
  EXPECT_TRUE(w.ok());
  return std::move(*w);
}

// Every mip-m sample must equal the mip-0 sample it decimates (clamped to the world).
void expect_mips_consistent(const World& w) {
  const WorldParams& p = w.params();
  for (int32_t m = 1; m < p.mip_count(); ++m) {
    const RectI tiles = p.tile_range(m);
    for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
      for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
        const auto tile = w.coarse_tile(m, int32_t(tx), int32_t(ty));
        ASSERT_EQ(tile.size(), size_t(kTileSamples));
        for (int64_t j = 0; j < kTileSize; ++j) {
          for (int64_t i = 0; i < kTileSize; ++i) {
            const int64_t gx = (tx * kTileSize + i) << m, gy = (ty * kTileSize + j) << m;
            ASSERT_EQ(tile[size_t(j * kTileSize + i)], w.coarse(gx, gy))
                << "mip " << m << " tile " << tx << "," << ty << " sample " << i << "," << j;
          }
        }
        ASSERT_EQ(w.tile_state({Layer::kCoarse, uint8_t(m), int32_t(tx), int32_t(ty)}).hash,
                  hash_coarse_tile(tile));
      }
    }
  }
}

TEST(World, MipsStayConsistentAfterRandomDirtyRects) {
  // Negative, unaligned origin so mips have tiles partly outside the world.
  const WorldParams p = small_params(-3, -1, 5, 3);
  World w = random_world(p, 1);
  expect_mips_consistent(w);
  std::mt19937 rng(7);
  const RectI world = p.sample_rect();
  for (int round = 0; round < 40; ++round) {
    const int64_t x0 = world.x0 + int64_t(rng() % uint32_t(world.width()));
    const int64_t y0 = world.y0 + int64_t(rng() % uint32_t(world.height()));
    const RectI r =
        RectI{x0, y0, x0 + 1 + int64_t(rng() % 300), y0 + 1 + int64_t(rng() % 300)}.intersect(world);
    std::vector<uint16_t> v(size_t(r.area()));
    for (auto& s : v) s = uint16_t(rng());
    w.write_coarse(r, v);
    w.commit(uint64_t(round + 1));
  }
  // Writes touching the world's edges must refresh the clamped samples beyond them.
  std::vector<uint16_t> edge(size_t(world.height()), 4242);
  w.write_coarse({world.x1 - 1, world.y0, world.x1, world.y1}, edge);
  w.commit(100);
  expect_mips_consistent(w);
}

TEST(World, TileHashChangesWithAnySampleAndNotOtherwise) {
  World w = random_world(small_params(), 2);
  const TileCoord c{Layer::kCoarse, 0, 1, 1};
  const uint64_t before = w.tile_state(c).hash;
  const uint64_t world_before = w.world_hash();
  for (int64_t i : {0, 1, 255, 256 * 128 + 77, 65535}) {
    const int64_t gx = 256 + i % 256, gy = 256 + i / 256;
    const uint16_t old = w.coarse(gx, gy);
    const uint16_t flipped = uint16_t(old ^ 1);
    w.write_coarse({gx, gy, gx + 1, gy + 1}, std::span(&flipped, 1));
    w.commit(1);
    EXPECT_NE(w.tile_state(c).hash, before) << "sample " << i;
    EXPECT_NE(w.world_hash(), world_before);
    w.write_coarse({gx, gy, gx + 1, gy + 1}, std::span(&old, 1));
    w.commit(2);
    EXPECT_EQ(w.tile_state(c).hash, before) << "restoring sample " << i << " must restore the hash";
    EXPECT_EQ(w.world_hash(), world_before);
  }
}

TEST(World, WritingIdenticalSamplesChangesNoVersion) {
  World w = random_world(small_params(), 3);
  std::vector<uint16_t> same(100 * 100);
  const RectI r{200, 200, 300, 300};
  w.read_coarse(r, same);
  EXPECT_EQ(w.write_coarse(r, same), 0);
  EXPECT_TRUE(w.commit(5).empty());
  EXPECT_EQ(w.tile_state({Layer::kCoarse, 0, 0, 0}).version, 0u);
}

TEST(World, CommitReportsChangedRectsMergedPerTileWithVersions) {
  World w(small_params(), 1000);
  // Two separate changes in tile (0,0) and one crossing into (1,0).
  const uint16_t v = 7;
  w.write_coarse({10, 10, 11, 11}, std::span(&v, 1));
  w.write_coarse({20, 30, 21, 31}, std::span(&v, 1));
  std::vector<uint16_t> row(4, 9);
  w.write_coarse({254, 5, 258, 6}, row);
  const auto changes = w.commit(42);
  std::vector<TileChange> mip0;
  for (const auto& c : changes) {
    if (c.coord.mip == 0) mip0.push_back(c);
    EXPECT_EQ(c.base_version, 0u);
    EXPECT_EQ(c.new_version, 42u);
  }
  ASSERT_EQ(mip0.size(), 2u);
  EXPECT_EQ(mip0[0].coord, (TileCoord{Layer::kCoarse, 0, 0, 0}));
  EXPECT_EQ(mip0[0].rect, (RectI{10, 5, 256, 31}));
  EXPECT_EQ(mip0[1].coord, (TileCoord{Layer::kCoarse, 0, 1, 0}));
  EXPECT_EQ(mip0[1].rect, (RectI{0, 5, 2, 6}));
  EXPECT_EQ(w.tile_state({Layer::kCoarse, 0, 1, 0}).version, 42u);
  EXPECT_EQ(w.tile_state({Layer::kCoarse, 0, 2, 1}).version, 0u);
  // Mip 1 holds even samples only: (10,10), (20,30) and (254,..) are even columns/rows? (10,10)
  // and (20,30) are; row 5 is odd, so the 4-sample row changes no mip-1 sample.
  bool mip1 = false;
  for (const auto& c : changes) {
    if (c.coord.mip == 1) {
      mip1 = true;
      EXPECT_EQ(c.rect, (RectI{5, 5, 11, 16}));
    }
  }
  EXPECT_TRUE(mip1);
}

TEST(World, DetailLayerIsSparseAndZeroTilesAreNotStored) {
  World w(small_params(), 100);
  EXPECT_EQ(w.detail_tile_count(), 0u);
  const uint64_t h0 = w.world_hash();
  const int8_t d = -5;
  w.write_detail({1000, 900, 1001, 901}, std::span(&d, 1));  // detail grid is 4x finer
  const auto changes = w.commit(1);
  ASSERT_EQ(changes.size(), 1u);
  EXPECT_EQ(changes[0].coord, (TileCoord{Layer::kDetail, 0, 3, 3}));
  EXPECT_EQ(w.detail_tile_count(), 1u);
  EXPECT_EQ(w.detail(1000, 900), -5);
  EXPECT_NE(w.world_hash(), h0);
  const int8_t zero = 0;
  w.write_detail({1000, 900, 1001, 901}, std::span(&zero, 1));
  w.commit(2);
  EXPECT_EQ(w.detail_tile_count(), 0u) << "an all-zero detail tile must not be stored";
  EXPECT_EQ(w.world_hash(), h0) << "absent and all-zero detail must hash the same";
  EXPECT_EQ(w.tile_state({Layer::kDetail, 0, 3, 3}).version, 2u);
}

TEST(World, FarFromOriginBehavesLikeOrigin) {
  // Same samples at origin tile 0 and 10,000 km away (at 1 m/sample: 39,064 tiles, a multiple of the coarsest
  // mip's span).
  const WorldParams near = small_params(0, 0);
  const WorldParams far = small_params(39064, -39064);  // a multiple of 2^mips tiles
  std::mt19937 rng(9);
  std::vector<uint16_t> s(size_t(near.sample_rect().area()));
  for (auto& v : s) v = uint16_t(rng());
  World a = *World::from_samples(near, s), b = *World::from_samples(far, s);
  const int64_t dx = far.sample_rect().x0, dy = far.sample_rect().y0;
  for (int i = 0; i < 1000; ++i) {
    const int64_t x = int64_t(rng() % 768), y = int64_t(rng() % 512);
    ASSERT_EQ(a.coarse(x, y), b.coarse(x + dx, y + dy));
  }
  const int32_t mips = near.mip_count();
  for (int32_t m = 0; m < mips; ++m) {
    const RectI ta = near.tile_range(m), tb = far.tile_range(m);
    EXPECT_EQ(ta.width(), tb.width());
    EXPECT_EQ(ta.height(), tb.height());
  }
}

TEST(World, FromSamplesRejectsWrongSampleCount) {
  std::vector<uint16_t> s(10);
  const auto w = World::from_samples(small_params(), s);
  ASSERT_FALSE(w.ok());
  EXPECT_EQ(w.error().field, "samples");
}

// A re-import at another scale must not hash like the original: the world hash covers the
// parameters; the content hash (what format 1 logs recorded) does not.
TEST(World, WorldHashCoversTheWorldsParametersContentHashDoesNot) {
  const WorldParams a = small_params();
  const World base(a, 1000);
  auto changed = [&](auto edit) {
    WorldParams p = a;
    edit(p);
    return World(p, 1000);
  };
  const World variants[] = {
      changed([](WorldParams& p) { p.meters_per_sample *= 2; }),
      changed([](WorldParams& p) { p.meters_per_unit *= 2; }),
      changed([](WorldParams& p) { p.height_offset += 1; }),
      changed([](WorldParams& p) { p.detail_factor = p.detail_factor == 4 ? 2 : 4; }),
      changed([](WorldParams& p) { p.detail_meters_per_unit *= 2; }),
  };
  for (const World& v : variants) {
    EXPECT_NE(v.world_hash(), base.world_hash());
    EXPECT_EQ(v.content_hash(), base.content_hash());
  }
  // Moved or resized, the tile coordinates differ, so both hashes do.
  EXPECT_NE(changed([](WorldParams& p) { p.origin_tile_x += 1; }).world_hash(), base.world_hash());
  EXPECT_EQ(World(a, 1000).world_hash(), base.world_hash());
  EXPECT_EQ(base.world_hash(), world_hash_of(a, base.content_hash()));
}

}  // namespace
}  // namespace loam
