// A world as a base plus edits (protocol/world.h, protocol/base/tile_base.h): untouched tiles
// come from the base and cost nothing until read, evicted tiles come back the same, the
// world hash needs no pass over the world, a world on a refined base behaves exactly like a
// dense copy of the same samples, and snapshots hold only the edited tiles.
#include <gtest/gtest.h>

#include <filesystem>
#include <vector>

#include "dem/refined_default.h"
#include "protocol/base/tile_base.h"
#include "protocol/snapshot/snapshot.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/texture_registry.h"
#include "protocol/tile_hash.h"
#include "protocol/world.h"
#include "tests/support/small_refined.h"
#include "tests/support/world_compare.h"

namespace loam {
namespace {

// A 2 x 1 tile world on a refined 9 x 5 source (x64): the refined extent (576 x 320) is larger
// than the world, and mip 1's tile reaches past the world's bottom edge, so the base's edge
// clamping is exercised.
using test::SmallRefined;
SmallRefined small_refined() {
  SmallRefined s = test::small_refined();
  EXPECT_TRUE(s.base != nullptr);
  return s;
}

// The same samples as a dense world (every tile written over a fill of 0).
World dense_copy(const World& w) {
  const RectI r = w.params().sample_rect();
  std::vector<uint16_t> samples(size_t(r.area()));
  w.read_coarse(r, samples);
  auto d = World::from_samples(w.params(), samples);
  EXPECT_TRUE(d.ok());
  return std::move(*d);
}

void expect_every_mip_tile_equal(const World& a, const World& b) {
  EXPECT_EQ(test::first_tile_difference(a, b, {.versions = false, .detail = false}), std::nullopt);
}

QuantizedStamp crater_at(int64_t x, int64_t y, uint32_t radius, int32_t intensity) {
  QuantizedStamp q;
  q.kind = StampKind::kCrater;
  q.center_x = x * 256;
  q.center_y = y * 256;
  q.radius = radius * 256;
  q.intensity = intensity * 256;
  q.shape = 20000;
  return q;
}

TEST(WorldBase, AnUntouchedWorldOfTheRefinedDefaultHashesWithoutGeneratingATile) {
  auto rw = load_refined_default();
  ASSERT_TRUE(rw.ok()) << rw.error().describe();
  auto base = RefinedTileBase::create(rw->base, rw->params);
  ASSERT_TRUE(base.ok()) << base.error().describe();
  World w(rw->params, *base);
  const uint64_t h = w.world_hash();
  EXPECT_EQ(w.base_tiles_generated(), 0u);
  EXPECT_EQ(w.edited_coarse_tile_count(), 0u);
  // Another parameter (the vertical offset) gives another world hash with the same base.
  WorldParams other = rw->params;
  other.height_offset += 1.0;
  EXPECT_NE(World(other, *base).world_hash(), h);
}

// A server answers Subscribe with versions and queues what it will read for its prefetcher:
// neither may make a tile on the receiving thread.
TEST(WorldBase, TileVersionsAndTheBaseReadsANewTileNeedsCostNoTile) {
  const SmallRefined s = small_refined();
  World w(s.params, s.base);
  const TileCoord c{Layer::kCoarse, 0, 1, 0};
  EXPECT_EQ(w.tile_version(c), 0u);
  EXPECT_TRUE(w.needs_base_read(0, 1, 0));
  EXPECT_FALSE(w.needs_base_read(0, 9, 9)) << "outside the world";
  EXPECT_EQ(w.base_tiles_generated(), 0u);
  (void)w.coarse_tile(0, 1, 0);
  EXPECT_FALSE(w.needs_base_read(0, 1, 0)) << "cached now";
  ASSERT_TRUE(apply_stamp(w, crater_at(300, 100, 20, -100)).ok());
  w.commit(5);
  EXPECT_EQ(w.tile_version(c), 5u);
  EXPECT_EQ(w.tile_version(c), w.tile_state(c).version);
  EXPECT_FALSE(w.needs_base_read(0, 1, 0)) << "edited";
}

TEST(WorldBase, ATileEvictedAndReadAgainHashesTheSameAndTheCacheStaysInItsBudget) {
  const SmallRefined s = small_refined();
  World w(s.params, s.base);
  w.set_base_cache_budget(size_t(kTileSamples) * sizeof(uint16_t));  // one tile
  std::vector<uint64_t> first;
  for (int32_t m = 0; m < s.params.mip_count(); ++m) {
    const RectI t = s.params.tile_range(m);
    for (int64_t tx = t.x0; tx < t.x1; ++tx)
      first.push_back(w.tile_state({Layer::kCoarse, uint8_t(m), int32_t(tx), 0}).hash);
  }
  const uint64_t generated = w.base_tiles_generated();
  EXPECT_EQ(generated, 3u);  // two mip-0 tiles, one mip-1 tile
  w.trim_base_cache();
  EXPECT_LE(w.base_cache_bytes(), w.base_cache_budget());
  size_t i = 0;
  for (int32_t m = 0; m < s.params.mip_count(); ++m) {
    const RectI t = s.params.tile_range(m);
    for (int64_t tx = t.x0; tx < t.x1; ++tx) {
      EXPECT_EQ(w.tile_state({Layer::kCoarse, uint8_t(m), int32_t(tx), 0}).hash, first[i++]);
      w.trim_base_cache();
    }
  }
  EXPECT_EQ(w.base_tiles_generated(), generated) << "tile hashes outlive the cache: nothing generated again";
  for (int32_t m = 0; m < s.params.mip_count(); ++m) {
    const RectI t = s.params.tile_range(m);
    for (int64_t tx = t.x0; tx < t.x1; ++tx) (void)w.coarse_tile(m, int32_t(tx), 0);
    w.trim_base_cache();
  }
  EXPECT_GT(w.base_tiles_generated(), generated) << "evicted tiles were generated again when read";
  i = 0;
  for (int32_t m = 0; m < s.params.mip_count(); ++m) {
    const RectI t = s.params.tile_range(m);
    for (int64_t tx = t.x0; tx < t.x1; ++tx) {
      const auto samples = w.coarse_tile(m, int32_t(tx), 0);
      EXPECT_EQ(hash_coarse_tile(samples), first[i++]) << "the regenerated samples hash as before";
    }
  }
  w.trim_base_cache();
  EXPECT_LE(w.base_cache_bytes(), w.base_cache_budget());
}

TEST(WorldBase, StampsOnARefinedBaseMatchADenseCopyAtEveryMipIncludingBeyondTheEdge) {
  const SmallRefined s = small_refined();
  World based(s.params, s.base);
  World dense = dense_copy(based);
  expect_every_mip_tile_equal(based, dense);
  // Craters across the tile seam and over the bottom edge.
  for (const QuantizedStamp& q : {crater_at(256, 128, 40, -300), crater_at(100, 250, 30, 200)}) {
    ASSERT_TRUE(apply_stamp(based, q).ok());
    ASSERT_TRUE(apply_stamp(dense, q).ok());
  }
  based.commit(1);
  dense.commit(1);
  expect_every_mip_tile_equal(based, dense);
  EXPECT_EQ(based.legacy_content_hash(), dense.legacy_content_hash());
  EXPECT_LE(based.edited_coarse_tile_count(), 3u);
}

TEST(WorldBase, WritingTheBaseSamplesBackHashesAsUntouched) {
  const SmallRefined s = small_refined();
  World w(s.params, s.base);
  const uint64_t untouched = w.world_hash();
  const RectI r{10, 10, 20, 20};
  std::vector<uint16_t> before(size_t(r.area())), raised(size_t(r.area()));
  w.read_coarse(r, before);
  for (size_t i = 0; i < raised.size(); ++i) raised[i] = uint16_t(before[i] + 7);
  EXPECT_EQ(w.write_coarse(r, raised), r.area());
  w.commit(1);
  EXPECT_NE(w.world_hash(), untouched);
  w.write_coarse(r, before);
  w.commit(2);
  EXPECT_EQ(w.world_hash(), untouched);
  // The tile is still edited (its version moved on), but its content is the base's.
  EXPECT_EQ(w.tile_state({Layer::kCoarse, 0, 0, 0}).version, 2u);
}

TEST(WorldBase, VersionZeroIsTheBaseOnlyWhenNothingWasCommittedAtVersionZero) {
  const SmallRefined s = small_refined();
  World based(s.params, s.base);
  EXPECT_TRUE(based.initial_is_base());
  ASSERT_TRUE(apply_stamp(based, crater_at(256, 128, 300, -300)).ok());  // every tile, every mip
  based.commit(1);
  EXPECT_TRUE(based.initial_is_base()) << "later edits keep version 0 the base's";
  // Samples written at version 0 over a fill (an imported DEM) are not the base, even once
  // every tile has been edited since.
  World dense = dense_copy(World(s.params, s.base));
  EXPECT_FALSE(dense.initial_is_base());
  ASSERT_TRUE(apply_stamp(dense, crater_at(256, 128, 300, -300)).ok());
  dense.commit(1);
  EXPECT_FALSE(dense.initial_is_base());
}

TEST(WorldBase, ACopiedWorldIsIndependentOfItsOriginal) {
  const SmallRefined s = small_refined();
  World a(s.params, s.base);
  const uint16_t v = a.coarse(5, 5);  // leaves a's lookup memo on tile (0, 0)
  World b = a;
  std::vector<uint16_t> one{uint16_t(v + 1)};
  b.write_coarse({5, 5, 6, 6}, one);
  EXPECT_EQ(a.coarse(5, 5), v);
  EXPECT_EQ(b.coarse(5, 5), v + 1);
}

TEST(WorldBase, ASnapshotHoldsOnlyEditedTilesAndNeedsItsBase) {
  const SmallRefined s = small_refined();
  World w(s.params, s.base);
  ASSERT_TRUE(apply_stamp(w, crater_at(60, 60, 20, -100)).ok());
  w.commit(1);
  const auto dir = std::filesystem::temp_directory_path() / "loam_world_base_snapshot";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  TextureRegistry textures;
  auto path = write_snapshot(dir.string(), w, 1, 0, textures, {});
  ASSERT_TRUE(path.ok()) << path.error().describe();
  auto manifest = read_snapshot_manifest(*path);
  ASSERT_TRUE(manifest.ok());
  EXPECT_EQ(manifest->coarse_tiles, 1u);
  EXPECT_EQ(manifest->base_identity, s.base->identity());
  auto loaded = read_snapshot(*path, s.base);
  ASSERT_TRUE(loaded.ok()) << loaded.error().describe();
  EXPECT_EQ(loaded->world.world_hash(), w.world_hash());
  EXPECT_TRUE(loaded->world.initial_is_base()) << "recorded in the manifest";
  expect_every_mip_tile_equal(loaded->world, w);
  auto without = read_snapshot(*path);
  ASSERT_FALSE(without.ok());
  EXPECT_EQ(without.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(without.error().message.find("refined"), std::string::npos) << without.error().message;
  std::filesystem::remove_all(dir);
}

// A client's mirror forgets a tile it no longer holds: the tile reads as the base again, its
// samples are freed, its version is 0, and the content hash is the untouched world's.
TEST(WorldBase, DiscardedTileReadsAsTheBaseAgainAndHoldsNoSamples) {
  const SmallRefined r = small_refined();
  World w(r.params, r.base);
  w.set_mip0_only(true);
  const uint64_t untouched = w.content_hash();
  std::vector<uint16_t> base0(kTileSamples);
  w.read_coarse(tile_rect(1, 0), base0);
  ASSERT_TRUE(apply_stamp(w, crater_at(300, 100, 40, 200)).ok());
  w.commit(7);
  EXPECT_EQ(w.edited_coarse_tile_count(), 1u);  // mip 0 only: no mip tile was made
  EXPECT_EQ(w.tile_state({Layer::kCoarse, 0, 1, 0}).version, 7u);
  std::vector<int8_t> d(100, 5);
  w.write_detail({0, 0, 10, 10}, d);
  w.commit(8);
  w.discard_tile(Layer::kCoarse, 1, 0);
  w.discard_tile(Layer::kDetail, 0, 0);
  EXPECT_EQ(w.edited_coarse_tile_count(), 0u);
  EXPECT_EQ(w.edited_bytes(), 0u);
  EXPECT_EQ(w.detail_tile_count(), 0u);
  EXPECT_EQ(w.tile_state({Layer::kCoarse, 0, 1, 0}).version, 0u);
  std::vector<uint16_t> now(kTileSamples);
  w.read_coarse(tile_rect(1, 0), now);
  EXPECT_EQ(now, base0);
  EXPECT_EQ(w.detail(3, 3), 0);
  EXPECT_EQ(w.content_hash(), untouched);
}

}  // namespace
}  // namespace loam
