// RegionStreamer (server/replication/region_streamer.h) and TileHashRound
// (tile_hash_round.h) on their own, over a small world: bulk leaves under each client's byte
// credit, turns rotate, encodes are bounded per round and shared, a client not reading gets
// nothing more; a hashes round reads only a few untouched tiles and leaves the rest for later.
#include "server/replication/region_streamer.h"

#include <gtest/gtest.h>

#include <map>

#include "protocol/base/tile_base.h"
#include "server/replication/tile_hash_round.h"

namespace loam::server {
namespace {

using namespace std::chrono_literals;

const CoreTime kStreamerStart = CoreTime{} + 100s;

WorldParams small_world() {
  WorldParams p;
  p.tiles_x = 4;
  p.tiles_y = 2;
  return p;
}

// A base whose samples differ from tile to tile (regions do not all encode alike) and that is
// not uniform (untouched tiles must be made to be hashed).
class RampBase final : public TileBase {
 public:
  void coarse_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const override {
    for (size_t i = 0; i < out.size(); ++i)
      out[i] = uint16_t(1000 + mip * 300 + tx * 40 + ty * 7 + int32_t(i % 97));
    ++made;
  }
  uint64_t identity() const override { return 7; }
  std::string describe() const override { return "ramp"; }
  mutable int made = 0;
};

struct StreamClient {
  ClientTiles tiles;
  TokenBucket credit;
};

// A client subscribed to every mip-0 tile, holding none of them.
StreamClient subscribed_to_all(const World& w, const RegionStreamer& s, CoreTime now) {
  StreamClient c{{}, s.credit(now)};
  const RectI r = w.params().tile_range(0);
  for (int32_t ty = int32_t(r.y0); ty < int32_t(r.y1); ++ty)
    for (int32_t tx = int32_t(r.x0); tx < int32_t(r.x1); ++tx) {
      const TileCoord t{Layer::kCoarse, 0, tx, ty};
      c.tiles.subscribe(t, std::nullopt, w.tile_version(t), std::nullopt);
    }
  return c;
}

struct Sent {
  std::map<uint32_t, uint64_t> bytes;
  std::vector<uint32_t> order;  // the client of each frame
};

TEST(RegionStreamer, ANewClientsCreditStartsEmptyAndBulkLeavesUnderItsBudget) {
  const World w(small_world(), std::make_shared<RampBase>());
  const TileHistory history(64, 64);
  ServerConfig config;
  config.client_bytes_per_second = 4000;
  RegionStreamer s(config);
  StreamClient c = subscribed_to_all(w, s, kStreamerStart);
  const size_t tiles = c.tiles.due_count();
  ASSERT_EQ(tiles, 8u);
  Sent sent;
  const auto send = [&](uint32_t id, FramePtr f) {
    sent.bytes[id] += f->size();
    sent.order.push_back(id);
  };
  const BulkClient one[] = {{1, &c.tiles, &c.credit}};
  EXPECT_EQ(s.stream(one, w, history, kStreamerStart, {}, send).regions, 0u) << "no credit yet";
  // A second later: a second's budget, spent whole regions at a time (the last may overdraw).
  const BulkRound r = s.stream(one, w, history, kStreamerStart + 1s, {}, send);
  EXPECT_GE(r.regions, 1u);
  EXPECT_LT(r.regions, tiles);
  EXPECT_LE(c.credit.level(), 0.0);
  EXPECT_EQ(c.tiles.due_count(), tiles - r.regions);
  // Enough seconds later, everything has gone, each tile once.
  uint64_t total = r.regions;
  for (int i = 2; i < 60 && c.tiles.due_count() > 0; ++i)
    total += s.stream(one, w, history, kStreamerStart + std::chrono::seconds(i), {}, send).regions;
  EXPECT_EQ(total, tiles);
  EXPECT_EQ(c.tiles.due_count(), 0u);
}

TEST(RegionStreamer, TurnsRotateAndEncodesAreBoundedPerRoundAndShared) {
  const World w(small_world(), std::make_shared<RampBase>());
  const TileHistory history(64, 64);
  ServerConfig config;
  config.client_bytes_per_second = 0;  // no byte limit: only the encode bound
  config.max_encodes_per_tick = 3;
  RegionStreamer s(config);
  StreamClient a = subscribed_to_all(w, s, kStreamerStart), b = subscribed_to_all(w, s, kStreamerStart);
  const BulkClient both[] = {{1, &a.tiles, &a.credit}, {2, &b.tiles, &b.credit}};
  Sent sent;
  const auto send = [&](uint32_t id, FramePtr f) {
    sent.bytes[id] += f->size();
    sent.order.push_back(id);
  };
  // Round 1: client 1 first; three encodes, then the second client takes only what is cached.
  const BulkRound r1 = s.stream(both, w, history, kStreamerStart, {}, send);
  EXPECT_EQ(s.frames().counters().encodes, 3u);
  EXPECT_EQ(r1.regions, 6u) << "3 encoded for client 1, the same 3 from the cache for client 2";
  ASSERT_FALSE(sent.order.empty());
  EXPECT_EQ(sent.order.front(), 1u);
  // Round 2: client 2 goes first.
  sent.order.clear();
  s.stream(both, w, history, kStreamerStart + 33ms, {}, send);
  ASSERT_FALSE(sent.order.empty());
  EXPECT_EQ(sent.order.front(), 2u);
  EXPECT_EQ(s.frames().counters().encodes, 6u);
  EXPECT_EQ(sent.bytes[1], sent.bytes[2]) << "the same tiles, the same bytes";
}

TEST(RegionStreamer, AClientNotReadingGetsNoMoreBulk) {
  const World w(small_world(), std::make_shared<RampBase>());
  const TileHistory history(64, 64);
  ServerConfig config;
  config.client_bytes_per_second = 4000;
  RegionStreamer s(config);
  StreamClient c = subscribed_to_all(w, s, kStreamerStart);
  const BulkClient one[] = {{1, &c.tiles, &c.credit}};
  int frames = 0;
  const auto send = [&](uint32_t, FramePtr) { ++frames; };
  // Over a second's budget still queued on its socket: nothing, whatever its credit.
  const auto unsent = [](uint32_t) { return uint64_t(4001); };
  EXPECT_EQ(s.stream(one, w, history, kStreamerStart + 5s, unsent, send).regions, 0u);
  EXPECT_EQ(frames, 0);
  EXPECT_GT(s.stream(
                 one, w, history, kStreamerStart + 6s, [](uint32_t) { return uint64_t(0); }, send)
                .regions,
            0u);
}

TEST(TileHashRound, AnUntouchedTileIsReadOnlyWithinTheRoundsBudgetAndTheRestWait) {
  auto base = std::make_shared<RampBase>();
  World w(small_world(), base);
  ClientTiles tiles;
  const RectI r = w.params().tile_range(0);
  for (int32_t ty = int32_t(r.y0); ty < int32_t(r.y1); ++ty)
    for (int32_t tx = int32_t(r.x0); tx < int32_t(r.x1); ++tx)
      tiles.subscribe({Layer::kCoarse, 0, tx, ty}, 0, 0, std::nullopt);
  TileHashRound round(3);
  const auto msgs = round.hashes(tiles, w);
  ASSERT_EQ(msgs.size(), 1u);
  EXPECT_EQ(msgs[0].entries.size(), 3u);
  EXPECT_EQ(round.later().size(), 5u);
  EXPECT_EQ(base->made, 3);
  for (const auto& e : msgs[0].entries) {
    EXPECT_EQ(e.version, 0u);
    EXPECT_EQ(e.hash, w.tile_state(e.tile).hash);
  }
  // A later round: the three are known now and cost nothing; three more are read.
  TileHashRound next(3);
  EXPECT_EQ(next.hashes(tiles, w)[0].entries.size(), 6u);
  EXPECT_EQ(next.later().size(), 2u);
}

TEST(TileHashRound, ManyTilesAreSplitIntoMessagesOfAtMostTheWireBound) {
  WorldParams p;
  p.tiles_x = 40;
  p.tiles_y = 30;
  const World w(p, 500);  // uniform: every tile's hash is known without a read
  ClientTiles tiles;
  size_t n = 0;
  for (int32_t ty = 0; ty < 30; ++ty)
    for (int32_t tx = 0; tx < 40; ++tx, ++n) tiles.subscribe({Layer::kCoarse, 0, tx, ty}, 0, 0, std::nullopt);
  TileHashRound round(0);
  const auto msgs = round.hashes(tiles, w);
  size_t entries = 0;
  for (const auto& m : msgs) {
    EXPECT_LE(m.entries.size(), wire::kMaxTileHashEntries);
    entries += m.entries.size();
  }
  EXPECT_EQ(entries, n);
  EXPECT_EQ(msgs.size(), (n + wire::kMaxTileHashEntries - 1) / wire::kMaxTileHashEntries);
  EXPECT_TRUE(round.later().empty());
}

}  // namespace
}  // namespace loam::server
