// What docs/protocol.md states about the session, pinned against a real loam-server: the
// answer to a stamp that changes nothing, the version-mismatch refusal, the idle timeout.
#include <gtest/gtest.h>

#include <chrono>
#include <map>

#include "integration_util.h"
#include "server_process.h"

namespace loam::test {
namespace {

using namespace std::chrono_literals;

// Messages after the handshake until the connection closes (or `timeout`), in order.
std::vector<wire::Message> messages_until_closed(client::Connection& c, std::chrono::milliseconds timeout) {
  std::vector<wire::Message> out;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    auto m = c.next(100ms);
    if (!m) break;  // closed
    if (m->has_value()) out.push_back(std::move(**m));
  }
  return out;
}

// A stamp centred on the middle of the world's first tile, in its own metres.
StampParams at_first_tile(const WorldParams& w) {
  StampParams p;
  p.center_x = (double(w.origin_tile_x) * kTileSize + 128.5) * w.meters_per_sample;
  p.center_y = (double(w.origin_tile_y) * kTileSize + 100.25) * w.meters_per_sample;
  p.radius = 12.0 * w.meters_per_sample;
  return p;
}

bool holds_all(const client::TerrainClient& c, const std::vector<TileCoord>& tiles) {
  for (const TileCoord& t : tiles)
    if (!c.store().version(t)) return false;
  return true;
}

TEST(DocsSemantics, AStampThatChangesNothingIsAckedWithASequenceAndSendsNoEventToAnyone) {
  const std::string dir = temp_data_dir("noop");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--hashes-every", "3"})) << server.log();
  client::TerrainClient sender, watcher;
  ASSERT_TRUE(sender.connect("127.0.0.1", server.port(), "sender").ok()) << server.log();
  ASSERT_TRUE(watcher.connect("127.0.0.1", server.port(), "watcher").ok());
  const WorldParams world = sender.welcome().world;
  std::vector<TileCoord> tiles = sender.all_coarse_tiles(0);
  const auto m1 = sender.all_coarse_tiles(1);
  tiles.insert(tiles.end(), m1.begin(), m1.end());
  ASSERT_TRUE(sender.subscribe(tiles).ok());
  ASSERT_TRUE(watcher.subscribe(tiles).ok());
  ASSERT_TRUE(sender.wait_until([&] { return holds_all(sender, tiles); }, 60s));
  ASSERT_TRUE(watcher.wait_until([&] { return holds_all(watcher, tiles); }, 60s));
  std::map<TileCoord, std::pair<uint64_t, uint64_t>> before;  // version, hash
  for (const TileCoord& t : tiles) before[t] = {*sender.store().version(t), sender.store().hash(t)};

  // max(old, target + δ) with the target at coarse value 0 and a quarter unit of intensity:
  // δ rounds to 0 everywhere, so every sample keeps max(old, 0) = old.
  StampParams p = at_first_tile(world);
  p.kind = StampKind::kGaussian;
  p.blend = BlendMode::kMax;
  p.target = world.height_offset;
  p.intensity = 0.25 * world.meters_per_unit;
  auto noop = validate_stamp(p, world);
  ASSERT_TRUE(noop.ok()) << noop.error().describe();
  const uint32_t s = *sender.deform(*noop);
  ASSERT_TRUE(sender.wait_until([&] { return sender.ack(s).has_value(); }, 30s));
  ASSERT_TRUE(sender.ack(s)->accepted);
  const uint64_t seq = sender.ack(s)->global_seq;
  EXPECT_GT(seq, 0u);

  // The promise: the first TileHashes after the ack follows the stamp's events, if any.
  for (client::TerrainClient* c : {&sender, &watcher}) {
    const size_t rounds = c->tile_hash_messages();
    ASSERT_TRUE(c->wait_until([&] { return c->tile_hash_messages() > rounds; }, 30s));
    EXPECT_EQ(c->last_event_seq(), 0u) << "an event came for a stamp that changed nothing";
    EXPECT_EQ(c->store().counters().events_applied + c->store().counters().events_buffered, 0u);
    for (const TileCoord& t : tiles) {
      EXPECT_EQ(*c->store().version(t), before[t].first) << to_string(t);
      EXPECT_EQ(c->store().hash(t), before[t].second) << to_string(t);
    }
    EXPECT_EQ(c->hash_mismatches(), 0u);
  }
  ASSERT_TRUE(sender.request_stats().ok());
  ASSERT_TRUE(sender.wait_until([&] { return sender.server_stats().has_value(); }, 30s));
  EXPECT_EQ(sender.server_stats()->events_sent, 0u);
  EXPECT_EQ(sender.server_stats()->deforms_accepted, 1u);
  EXPECT_EQ(sender.server_stats()->global_sequence, seq);

  // A stamp that changes the terrain next: the following sequence, and its event reaches both.
  p.blend = BlendMode::kAdd;
  p.target = 0.0;
  p.intensity = 40.0 * world.meters_per_unit;
  auto bump = validate_stamp(p, world);
  ASSERT_TRUE(bump.ok()) << bump.error().describe();
  const uint32_t s2 = *sender.deform(*bump);
  ASSERT_TRUE(sender.wait_until([&] { return sender.ack(s2).has_value(); }, 30s));
  ASSERT_TRUE(sender.ack(s2)->accepted);
  EXPECT_EQ(sender.ack(s2)->global_seq, seq + 1);
  for (client::TerrainClient* c : {&sender, &watcher})
    EXPECT_TRUE(c->wait_until([&] { return c->last_event_seq() == seq + 1; }, 30s));

  // The log holds the no-op at its sequence, and no tile took that sequence as its version.
  const World replayed = replayed_world(dir, seq);
  for (const TileCoord& t : tiles) EXPECT_EQ(replayed.tile_state(t).version, 0u) << to_string(t);
}

TEST(DocsSemantics, AnotherMajorVersionGetsErrorUnsupportedThenByeVersionMismatch) {
  ServerProcess server;
  ASSERT_TRUE(server.start(temp_data_dir("version"))) << server.log();
  client::Connection c;
  wire::Hello h;
  h.version_major = uint16_t(wire::kProtocolMajor - 1);
  h.client_name = "old";
  // connect() returns the Error: unsupported, naming the field.
  const auto w = c.connect("127.0.0.1", server.port(), h);
  ASSERT_FALSE(w.ok());
  EXPECT_EQ(w.error().code, ErrorCode::kUnsupported) << w.error().describe();
  EXPECT_EQ(w.error().field, "hello.version_major") << w.error().describe();
  // Then the Bye, then the close.
  const auto rest = messages_until_closed(c, 10s);
  ASSERT_FALSE(rest.empty()) << "nothing after the Error";
  const auto* bye = std::get_if<wire::Bye>(&rest.back());
  ASSERT_NE(bye, nullptr) << "the last message is not a Bye";
  // The wire decoder refuses the Hello before the session logic sees it (docs/protocol.md,
  // "Handshake and versions"); the Bye says why, so the peer knows to upgrade. (It said
  // protocol_error before, as for any undecodable frame.)
  EXPECT_EQ(bye->reason, wire::ByeReason::kVersionMismatch);
  const std::string ours = std::to_string(wire::kProtocolMajor) + "." + std::to_string(wire::kProtocolMinor);
  EXPECT_NE(bye->text.find("peer speaks protocol " + std::to_string(wire::kProtocolMajor - 1) + ".0"),
            std::string::npos)
      << bye->text;
  EXPECT_NE(bye->text.find(ours), std::string::npos) << bye->text;
  EXPECT_EQ(bye->text.rfind("hello.version_major: ", 0), 0u) << bye->text;
}

TEST(DocsSemantics, AnIdleClientGetsErrorInvalidArgumentThenByeTimeout) {
  ServerProcess server;
  ASSERT_TRUE(server.start(temp_data_dir("idle"), {"--idle-timeout", "1"})) << server.log();
  client::Connection c;
  wire::Hello h;
  h.client_name = "quiet";
  ASSERT_TRUE(c.connect("127.0.0.1", server.port(), h).ok());
  const auto msgs = messages_until_closed(c, 10s);
  ASSERT_GE(msgs.size(), 2u);
  const auto* err = std::get_if<wire::ErrorMsg>(&msgs[msgs.size() - 2]);
  const auto* bye = std::get_if<wire::Bye>(&msgs.back());
  ASSERT_NE(err, nullptr);
  ASSERT_NE(bye, nullptr);
  EXPECT_EQ(err->code, wire::WireErrorCode::kInvalidArgument);
  EXPECT_EQ(err->field, "");
  EXPECT_EQ(err->text, "idle timeout");
  EXPECT_EQ(bye->reason, wire::ByeReason::kTimeout);
  EXPECT_EQ(bye->text, "idle timeout");
}

}  // namespace
}  // namespace loam::test
