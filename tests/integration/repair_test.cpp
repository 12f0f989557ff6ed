// Repair from TileHashes against a real loam-server (docs/protocol.md, "TileHashes"): a client
// whose held tile went wrong (a flipped sample in its confirmed store, an event that never
// arrived) finds out from the server's hash rounds and gets the tile right again, by a region
// or a delta, within two rounds.
#include <gtest/gtest.h>

#include <chrono>

#include "fault_proxy.h"
#include "integration_util.h"
#include "server_process.h"

namespace loam::test {
namespace {

using namespace std::chrono_literals;

bool holds_all(const client::TerrainClient& c, const std::vector<TileCoord>& tiles) {
  for (const TileCoord& t : tiles)
    if (!c.store().version(t)) return false;
  return true;
}

std::vector<TileCoord> mips_0_and_1(const client::TerrainClient& c) {
  std::vector<TileCoord> tiles = c.all_coarse_tiles(0);
  const auto m1 = c.all_coarse_tiles(1);
  tiles.insert(tiles.end(), m1.begin(), m1.end());
  return tiles;
}

// Corrupts one sample of a held coarse tile through the store's public API: the same tile,
// at the same version, with sample (x, y) flipped.
void flip_sample(client::ConfirmedStore& store, const TileCoord& t, int32_t x, int32_t y) {
  const auto held = store.coarse_samples(t);
  std::vector<uint16_t> samples(held.begin(), held.end());
  ASSERT_EQ(samples.size(), size_t(kTileSamples));
  samples[size_t(y) * kTileSize + size_t(x)] ^= 0x0101;
  ASSERT_TRUE(store.replace<CoarseLayer>(t, *store.version(t), samples).ok());
}

// A gaussian bump in the middle of the world's first tile.
QuantizedStamp bump(const WorldParams& w) {
  StampParams p;
  p.kind = StampKind::kGaussian;
  p.center_x = (double(w.origin_tile_x) * kTileSize + 100.5) * w.meters_per_sample;
  p.center_y = (double(w.origin_tile_y) * kTileSize + 90.25) * w.meters_per_sample;
  p.radius = 10.0 * w.meters_per_sample;
  p.intensity = 30.0 * w.meters_per_unit;
  auto q = validate_stamp(p, w);
  EXPECT_TRUE(q.ok()) << q.error().describe();
  return q.ok() ? *q : QuantizedStamp{};
}

TEST(Repair, AFlippedSampleInTheConfirmedStoreIsDetectedByTileHashesAndReplacedByARegion) {
  ServerProcess server;
  ASSERT_TRUE(server.start(temp_data_dir("flip"), {"--hashes-every", "10"})) << server.log();
  client::TerrainClient c;
  ASSERT_TRUE(c.connect("127.0.0.1", server.port(), "held").ok()) << server.log();
  const std::vector<TileCoord> tiles = mips_0_and_1(c);
  ASSERT_TRUE(c.subscribe(tiles).ok());
  ASSERT_TRUE(c.wait_until([&] { return holds_all(c, tiles); }, 60s));
  // An edit first, so the tiles are at a version other than the initial terrain's.
  const uint32_t s = *c.deform(bump(c.welcome().world));
  ASSERT_TRUE(c.wait_until([&] { return c.ack(s) && c.last_event_seq() == c.ack(s)->global_seq; }, 30s));
  // A mip-0 tile and a mip-1 tile (held apart from the mip-0 mirror), each one sample off.
  const TileCoord t0 = tiles.front(), t1 = c.all_coarse_tiles(1).front();
  const uint64_t good0 = c.store().hash(t0), good1 = c.store().hash(t1);
  const uint64_t v0 = *c.store().version(t0), v1 = *c.store().version(t1);
  // Just after a round, so the next one is the first to see the corruption.
  const size_t rounds = c.tile_hash_messages();
  ASSERT_TRUE(c.wait_until([&] { return c.tile_hash_messages() > rounds; }, 30s));
  flip_sample(c.store(), t0, 17, 200);
  flip_sample(c.store(), t1, 255, 0);
  ASSERT_NE(c.store().hash(t0), good0);
  ASSERT_NE(c.store().hash(t1), good1);
  const uint64_t regions = c.store().counters().regions;
  const size_t flipped_at = c.tile_hash_messages();

  ASSERT_TRUE(c.wait_until([&] { return c.store().hash(t0) == good0 && c.store().hash(t1) == good1; }, 30s))
      << "not repaired; hash mismatches seen: " << c.hash_mismatches();
  EXPECT_LE(c.tile_hash_messages(), flipped_at + 2) << "repaired only after more than two hash rounds";
  EXPECT_GE(c.hash_mismatches(), 2u);
  EXPECT_GE(c.store().counters().regions, regions + 2) << "repaired by something other than regions";
  EXPECT_EQ(*c.store().version(t0), v0);
  EXPECT_EQ(*c.store().version(t1), v1);
  // And it stays right: the next round finds nothing.
  const uint64_t mismatches = c.hash_mismatches();
  const size_t now = c.tile_hash_messages();
  ASSERT_TRUE(c.wait_until([&] { return c.tile_hash_messages() > now; }, 30s));
  EXPECT_EQ(c.hash_mismatches(), mismatches);
}

TEST(Repair, AnEventLostOnTheWayIsDetectedByTileHashesAndRepairedByADeltaOverTheFaultProxy) {
  const std::string dir = temp_data_dir("lost");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--hashes-every", "10"})) << server.log();
  FaultProxy proxy(server.port(), {});
  client::TerrainClient far, editor;  // far: through the proxy; editor: direct
  ASSERT_TRUE(far.connect("127.0.0.1", proxy.port(), "far").ok()) << server.log();
  ASSERT_TRUE(editor.connect("127.0.0.1", server.port(), "editor").ok());
  const std::vector<TileCoord> tiles = mips_0_and_1(far);
  ASSERT_TRUE(far.subscribe(tiles).ok());
  ASSERT_TRUE(far.wait_until([&] { return holds_all(far, tiles); }, 60s));

  // Just after a round (one every 10 ticks, 333 ms), so the stamp is applied before the next
  // one, which is then the first after the loss.
  const size_t before = far.tile_hash_messages();
  ASSERT_TRUE(far.wait_until([&] { return far.tile_hash_messages() > before; }, 30s));
  const size_t rounds = far.tile_hash_messages();
  proxy.drop_next_frame_to_client(uint16_t(wire::MessageType::kDeformEvent));
  const uint32_t s = *editor.deform(bump(editor.welcome().world));
  ASSERT_TRUE(editor.wait_until([&] { return editor.ack(s).has_value(); }, 30s));
  ASSERT_TRUE(editor.ack(s)->accepted);
  const uint64_t seq = editor.ack(s)->global_seq;
  const uint64_t regions = far.store().counters().regions;

  const World expected = replayed_world(dir, seq);
  const TileCoord t0 = tiles.front();
  ASSERT_EQ(expected.tile_state(t0).version, seq) << "the stamp did not change the first tile";
  ASSERT_TRUE(far.wait_until([&] { return far.store().version(t0) == seq; }, 30s))
      << "the lost event's tile was never brought up to date; dropped frames: " << proxy.frames_dropped();
  EXPECT_EQ(proxy.frames_dropped(), 1u);
  EXPECT_EQ(far.last_event_seq(), 0u) << "the event was not lost";
  EXPECT_LE(far.tile_hash_messages(), rounds + 2) << "repaired only after more than two hash rounds";
  EXPECT_GT(far.store().counters().regions_partial, 0u) << "repaired by whole tiles, not by a delta patch";
  EXPECT_GT(far.store().counters().regions, regions);
  EXPECT_TRUE(store_matches(far, expected));
  EXPECT_EQ(far.hash_mismatches(), 0u) << "a held tile was wrong at the version it claimed";
}

}  // namespace
}  // namespace loam::test
