// Streaming (server/replication/core_streaming.cpp): events against regions, patches and deltas,
// budgets and order, encode once, the encode bound, hashes rounds, the best mode.
#include "tests/server/core_harness.h"

namespace loam::server {
namespace {

using namespace std::chrono_literals;
using core_test::CoreHarness;
using core_test::encoding_of;
using core_test::Received;

TEST(ReplicationCore, ShockwaveMipsTravelAsPatchesOverTheHeldVersion) {
  CoreHarness h;
  const ClientId a = h.join("a");
  h.send(a, h.subscribe_all(true));
  h.tick();
  h.clear();
  h.send(a, wire::Deform{1, h.stamp(StampKind::kShockwave, 300.0, 200.0, 4.0)});
  h.tick();
  const auto regions = h.of(a).all<wire::RegionUpdate>();
  ASSERT_FALSE(regions.empty());
  for (const auto& r : regions) {
    EXPECT_GT(r.tile.mip, 0);
    EXPECT_TRUE(r.patch);
    EXPECT_EQ(r.base_version, 0u);
    EXPECT_EQ(r.new_version, 1u);
  }
}

TEST(ReplicationCore, AShockwavesPatchesAreEncodedOnceForEveryClientInSync) {
  ServerConfig config;
  config.client_bytes_per_second = 0;
  CoreHarness h(config);
  std::vector<ClientId> ids;
  for (int i = 0; i < 6; ++i) ids.push_back(h.join("c" + std::to_string(i)));
  for (const ClientId id : ids) h.send(id, h.subscribe_all(true));
  h.tick();
  uint32_t seq = 0;
  for (int i = 0; i < 4; ++i) {
    const uint64_t before = h.core().region_counters().encodes;
    // Several in one tick, overlapping: the patches coalesce, the same way for every client.
    for (int j = 0; j < 4; ++j)
      h.send(ids[0], wire::Deform{++seq, h.stamp(StampKind::kShockwave, 200.0 + 40 * i + 9 * j, 300.0, 6.0)});
    h.tick();
    const size_t patches = h.of(ids[1]).all<wire::RegionUpdate>().size();
    for (const ClientId id : ids) EXPECT_EQ(h.of(id).all<wire::RegionUpdate>().size(), patches);
    EXPECT_EQ(h.core().region_counters().encodes - before, patches) << "shockwave " << i;
    h.clear();
  }
}

TEST(ReplicationCore, RegionsLeaveUnderTheClientsBudgetCoarsestMipFirst) {
  ServerConfig config;
  config.client_bytes_per_second = 128 << 10;
  CoreHarness h(config);
  const ClientId a = h.join("a");
  h.send(a, h.subscribe_all(false));
  const size_t tiles = h.core().tiles_of(a)->due_count();
  ASSERT_GT(tiles, 4u);
  int last_mip = 99;
  uint64_t sent_before = 0;
  int ticks = 0;
  while (h.core().tiles_of(a)->due_count() > 0 && ticks < 30 * 60) {
    h.tick();
    ++ticks;
    const uint64_t sent = h.of(a).region_bytes - sent_before;
    sent_before = h.of(a).region_bytes;
    // One tick's worth of credit, plus at most the one region that overdraws it.
    EXPECT_LE(sent, uint64_t(128 << 10) / 30 + 256 * 1024) << "tick " << ticks;
  }
  EXPECT_EQ(h.core().tiles_of(a)->due_count(), 0u);
  for (const auto& r : h.of(a).all<wire::RegionUpdate>()) {
    EXPECT_LE(r.tile.mip, last_mip);  // never a finer mip before a coarser one
    last_mip = r.tile.mip;
  }
  // The whole world took the time its bytes take at the budget (within a second's burst).
  const double seconds = ticks / 30.0;
  EXPECT_GE(seconds + 1.0, double(h.of(a).region_bytes) / double(128 << 10));
}

TEST(ReplicationCore, AJoinStormEncodesEachTileOnceForAllClients) {
  ServerConfig config;
  config.client_bytes_per_second = 0;  // no budget: all at once
  CoreHarness h(config);
  std::vector<ClientId> ids;
  for (int i = 0; i < 8; ++i) ids.push_back(h.join("c" + std::to_string(i)));
  for (const ClientId id : ids) h.send(id, h.subscribe_all(false));
  const size_t tiles = h.core().tiles_of(ids[0])->due_count();
  for (int i = 0; i < 200 && h.core().tiles_of(ids.back())->due_count() > 0; ++i) h.tick();
  for (const ClientId id : ids) EXPECT_EQ(h.core().tiles_of(id)->due_count(), 0u);
  EXPECT_EQ(h.core().region_counters().encodes, tiles);
  EXPECT_EQ(h.core().region_counters().hits, tiles * (ids.size() - 1));
}

TEST(ReplicationCore, EncodesPerTickAreBoundedSoATickStaysShort) {
  ServerConfig config;
  config.client_bytes_per_second = 0;
  config.max_encodes_per_tick = 3;
  CoreHarness h(config);
  const ClientId a = h.join("a");
  h.send(a, h.subscribe_all(false));
  h.tick();
  EXPECT_EQ(h.core().region_counters().encodes, 3u);
  h.tick();
  EXPECT_EQ(h.core().region_counters().encodes, 6u);
}

// On a generated base, an untouched tile's hash costs a refinement the first time: a hashes
// round makes a few and leaves the rest to later rounds, so a client subscribing a hundred new
// tiles does not stall the tick; every tile is hashed within a few rounds, and right.
TEST(ReplicationCore, AHashesRoundGeneratesAFewUntouchedTilesAndHashesTheRestInLaterRounds) {
  ServerConfig config;
  config.hashes_every_ticks = 1;
  config.prefetch_tiles = 0;
  CoreHarness h(config, kTerrainRefined);
  const ClientId a = h.join("a");
  wire::Subscribe sub;
  for (int32_t i = 0; i < 100; ++i)
    sub.entries.push_back({TileCoord{Layer::kCoarse, 0, 100 + i % 10, 100 + i / 10}, true, 0});
  h.send(a, sub);
  const World& w = h.core().terrain().world();
  std::map<TileCoord, uint64_t> hashed;
  int rounds = 0;
  while (hashed.size() < sub.entries.size() && rounds < 20) {
    h.clear();
    const uint64_t generated = w.base_tiles_generated();
    h.tick();
    ++rounds;
    EXPECT_LE(w.base_tiles_generated() - generated, 16u);
    size_t entries = 0;
    for (const wire::TileHashes& m : h.of(a).all<wire::TileHashes>()) {
      for (const wire::TileHashEntry& e : m.entries) {
        EXPECT_EQ(e.version, 0u);
        hashed[e.tile] = e.hash;
        ++entries;
      }
    }
    EXPECT_LE(entries, size_t(16 * rounds));  // the known ones again, and at most 16 new
  }
  EXPECT_EQ(hashed.size(), sub.entries.size());
  EXPECT_EQ(rounds, 7);  // 100 tiles, 16 a round
  for (const auto& [t, hash] : hashed) EXPECT_EQ(hash, w.tile_state(t).hash) << to_string(t);
}

TEST(ReplicationCore, ARegionQueuedBehindTheBudgetLeavesAtTheTilesNewestVersion) {
  ServerConfig config;
  config.client_bytes_per_second = 1024;  // far below one tile a second
  CoreHarness h(config);
  const ClientId a = h.join("a"), editor = h.join("editor");
  h.send(a, h.subscribe_all(false));
  for (uint32_t i = 1; i <= 3; ++i)
    h.send(editor, wire::Deform{i, h.stamp(StampKind::kCrater, 100, 100, 10)});
  h.tick();
  // Nothing goes before credit accrues; then each region carries the version after all three.
  for (int i = 0; i < 30 * 120 && h.core().tiles_of(a)->due_count() > 0; ++i) h.tick();
  for (const auto& r : h.of(a).all<wire::RegionUpdate>()) {
    EXPECT_FALSE(r.patch);
    EXPECT_EQ(r.new_version, h.core().terrain().world().tile_state(r.tile).version);
  }
}

TEST(ReplicationCore, AClientResumingBehindGetsPatchesOfTheSamplesChangedSinceItsVersion) {
  ServerConfig config;
  config.client_bytes_per_second = 0;
  CoreHarness h(config);
  const ClientId editor = h.join("editor");
  for (uint32_t i = 1; i <= 5; ++i)
    h.send(editor, wire::Deform{i, h.stamp(StampKind::kCrater, 100.0 + 20 * i, 100.0, 8)});
  h.tick();
  // Back after the five stamps, holding every tile at the initial version.
  const ClientId back = h.join("back");
  h.send(back, h.subscribe_all(true));
  h.tick();
  const auto regions = h.of(back).all<wire::RegionUpdate>();
  ASSERT_FALSE(regions.empty());
  uint64_t samples = 0;
  for (const auto& r : regions) {
    EXPECT_TRUE(r.patch) << to_string(r.tile);
    EXPECT_EQ(r.base_version, 0u);
    EXPECT_EQ(r.new_version, h.core().terrain().world().tile_state(r.tile).version);
    samples += uint64_t(r.rect.area());
  }
  EXPECT_LT(samples, uint64_t(regions.size()) * kTileSamples / 8);
}

TEST(ReplicationCore, PatchesForAClientBehindAreDeltasAgainstTheSamplesItHolds) {
  ServerConfig config;
  config.client_bytes_per_second = 0;
  CoreHarness h(config);
  const World initial = h.core().terrain().world();
  const ClientId editor = h.join("editor");
  uint32_t seq = 0;
  for (int i = 0; i < 6; ++i) {
    h.send(editor, wire::Deform{++seq, h.stamp(StampKind::kCrater, 200.0 + 15 * i, 250.0 + 3 * i, 12)});
    h.send(editor, wire::Deform{++seq, h.stamp(StampKind::kGaussian, 240.0, 200.0 + 20 * i, 9)});
    h.tick();
  }
  const ClientId back = h.join("back");
  h.send(back, h.subscribe_all(true));  // holds everything at version 0
  h.tick();
  const World& now = h.core().terrain().world();
  const auto regions = h.of(back).all<wire::RegionUpdate>();
  ASSERT_FALSE(regions.empty());
  for (const auto& r : regions) {
    ASSERT_TRUE(r.patch);
    EXPECT_EQ(encoding_of(r), RegionEncoding::kDelta) << to_string(r.tile);
    // Decoded against the samples held at version 0, it gives the samples now.
    const auto held = copy_tile_rect(initial.coarse_tile(r.tile.mip, r.tile.tx, r.tile.ty), r.rect);
    auto decoded = decode_region(r.chunk, uint32_t(r.rect.width()), uint32_t(r.rect.height()),
                                 RegionRefs<uint16_t>{.base = held, .coarser = {}});
    ASSERT_TRUE(decoded.ok()) << decoded.error().describe();
    EXPECT_EQ(*decoded, copy_tile_rect(now.coarse_tile(r.tile.mip, r.tile.tx, r.tile.ty), r.rect))
        << to_string(r.tile);
  }
  EXPECT_EQ(h.core().region_counters().delta_encodes, regions.size());
}

TEST(ReplicationCore, AWholeTileSentToManyIsReencodedInTheBestModeOffTheTick) {
  ServerConfig config;
  config.client_bytes_per_second = 0;
  config.best_after_uses = 2;
  CoreHarness h(config);
  const ClientId a = h.join("a"), b = h.join("b");
  h.send(a, h.subscribe_all(false));
  h.send(b, h.subscribe_all(false));
  for (int i = 0; i < 100 && h.core().tiles_of(b)->due_count() > 0; ++i) h.tick();
  const uint64_t fast_bytes = h.of(b).region_bytes;
  h.core().finish_background_encodes();
  const RegionFrameCounters rc = h.core().region_counters();
  EXPECT_GT(rc.best_upgrades, 0u);
  EXPECT_GT(rc.best_bytes_saved, 0u);
  EXPECT_LT(rc.best_bytes_saved, fast_bytes / 4);  // a few percent: the fast mode is close
  // The cache holds every tile once, at its smaller size.
  EXPECT_EQ(rc.bytes_held, fast_bytes - rc.best_bytes_saved);
  // A third client gets the smaller frames, and they decode to the same tiles.
  const ClientId c = h.join("c");
  h.send(c, h.subscribe_all(false));
  for (int i = 0; i < 100 && h.core().tiles_of(c)->due_count() > 0; ++i) h.tick();
  EXPECT_EQ(h.of(c).region_bytes + rc.best_bytes_saved, fast_bytes);
  size_t best = 0;
  const World& w = h.core().terrain().world();
  for (const auto& r : h.of(c).all<wire::RegionUpdate>()) {
    if (encoding_of(r) == RegionEncoding::kBest) ++best;
    auto decoded = decode_region(r.chunk, kTileSize, kTileSize);
    ASSERT_TRUE(decoded.ok());
    const auto tile = w.coarse_tile(r.tile.mip, r.tile.tx, r.tile.ty);
    EXPECT_TRUE(std::equal(decoded->begin(), decoded->end(), tile.begin(), tile.end()));
  }
  EXPECT_EQ(best, rc.best_upgrades);
}

}  // namespace
}  // namespace loam::server
