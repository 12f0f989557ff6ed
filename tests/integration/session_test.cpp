// Integration tests: a real loam-server process, real sockets on loopback, clients built on
// client/net. Each test names the behaviour it pins.
#include <gtest/gtest.h>

#include <atomic>
#include <set>
#include <thread>

#include "dem/default_terrain.h"
#include "dem/dem_export.h"
#include "dem/stamp_texture_io.h"
#include "integration_util.h"
#include "server_process.h"

namespace loam::test {
namespace {

using namespace std::chrono_literals;

std::vector<TileCoord> subscription_for(const client::TerrainClient& c, int variant) {
  std::vector<TileCoord> tiles = c.all_coarse_tiles(0);
  if (variant % 2 == 1) {
    const auto m1 = c.all_coarse_tiles(1);
    tiles.insert(tiles.end(), m1.begin(), m1.end());
  }
  if (variant % 4 == 3) tiles.push_back({Layer::kDetail, 0, 0, 0});
  if (variant % 3 == 2) tiles.resize(tiles.size() / 2);  // partial interest
  return tiles;
}

TEST(Session, SixteenClientsDeformingConcurrentlyConvergeOnTheServersTiles) {
  const std::string dir = temp_data_dir("a");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--tick-hz", "60", "--hashes-every", "20"})) << server.log();

  constexpr int kClients = 16, kStampsEach = 12;
  std::vector<std::unique_ptr<client::TerrainClient>> clients;
  for (int i = 0; i < kClients; ++i) {
    auto c = std::make_unique<client::TerrainClient>();
    ASSERT_TRUE(c->connect("127.0.0.1", server.port(), "client" + std::to_string(i)).ok()) << server.log();
    ASSERT_TRUE(c->subscribe(subscription_for(*c, i)).ok());
    clients.push_back(std::move(c));
  }
  // Every client deforms from its own thread, waiting for its acks.
  std::vector<std::thread> threads;
  std::vector<uint64_t> max_seq(kClients, 0);
  std::vector<int> accepted(kClients, 0);
  for (int i = 0; i < kClients; ++i) {
    threads.emplace_back([&, i] {
      StampRng rng(uint32_t(1000 + i));
      client::TerrainClient& c = *clients[size_t(i)];
      std::vector<uint32_t> seqs;
      for (int k = 0; k < kStampsEach; ++k) {
        auto s = c.deform(random_stamp(rng, c.welcome().world));
        if (s.ok()) seqs.push_back(*s);
      }
      c.wait_until(
          [&] {
            for (uint32_t s : seqs)
              if (!c.ack(s)) return false;
            return true;
          },
          60s);
      for (uint32_t s : seqs) {
        const auto a = c.ack(s);
        if (a && a->accepted) {
          ++accepted[size_t(i)];
          max_seq[size_t(i)] = std::max(max_seq[size_t(i)], a->global_seq);
        }
      }
    });
  }
  for (auto& t : threads) t.join();
  uint64_t final_seq = 0;
  for (int i = 0; i < kClients; ++i) {
    EXPECT_EQ(accepted[size_t(i)], kStampsEach) << "client " << i;
    final_seq = std::max(final_seq, max_seq[size_t(i)]);
  }
  EXPECT_EQ(final_seq, uint64_t(kClients * kStampsEach));
  const World expected = replayed_world(dir, final_seq);
  for (int i = 0; i < kClients; ++i) {
    client::TerrainClient& c = *clients[size_t(i)];
    const bool converged = c.wait_until([&] { return bool(store_matches(c, expected)); }, 60s);
    EXPECT_TRUE(converged) << "client " << i << ": " << store_matches(c, expected).message() << " regions "
                           << c.store().counters().regions << " applied "
                           << c.store().counters().events_applied << " buffered "
                           << c.store().counters().events_buffered << " open " << c.connection().open()
                           << " in " << c.connection().bytes_in();
    EXPECT_EQ(c.hash_mismatches(), 0u) << "client " << i;
    EXPECT_EQ(c.store().buffered(), 0u) << "client " << i;
    EXPECT_TRUE(c.local_errors().empty()) << "client " << i << ": " << c.local_errors().front().describe();
  }
  // Clients applied events themselves rather than receiving every tile again.
  uint64_t applied = 0;
  for (auto& c : clients) applied += c->store().counters().events_applied;
  EXPECT_GT(applied, 0u);
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

}  // namespace
}  // namespace loam::test

namespace loam::test {
namespace {

using namespace std::chrono_literals;

// Kill -9 in the middle of a deform storm; every acknowledged stamp must survive the restart,
// both in the restarted server's world and in a replay of its log.
void kill_during_storm(uint32_t seed) {
  const std::string dir = temp_data_dir("seed" + std::to_string(seed));
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--tick-hz", "120", "--snapshot-every", "150"})) << server.log();
  constexpr int kClients = 4;
  std::vector<std::unique_ptr<client::TerrainClient>> clients;
  for (int i = 0; i < kClients; ++i) {
    auto c = std::make_unique<client::TerrainClient>();
    ASSERT_TRUE(c->connect("127.0.0.1", server.port(), "storm" + std::to_string(i)).ok());
    clients.push_back(std::move(c));
  }
  std::atomic<uint64_t> acked_total{0};
  std::atomic<bool> stop{false};
  std::vector<uint64_t> max_acked(kClients, 0);
  std::vector<std::thread> threads;
  for (int i = 0; i < kClients; ++i) {
    threads.emplace_back([&, i] {
      StampRng rng(seed * 100 + uint32_t(i));
      client::TerrainClient& c = *clients[size_t(i)];
      std::vector<uint32_t> outstanding;
      while (!stop) {
        while (outstanding.size() < 8) {
          auto s = c.deform(random_stamp(rng, c.welcome().world));
          if (!s.ok()) return;
          outstanding.push_back(*s);
        }
        if (!c.pump(20ms).ok()) return;  // the server is gone
        for (auto it = outstanding.begin(); it != outstanding.end();) {
          const auto a = c.ack(*it);
          if (!a) {
            ++it;
            continue;
          }
          if (a->accepted) {
            max_acked[size_t(i)] = std::max(max_acked[size_t(i)], a->global_seq);
            ++acked_total;
          }
          it = outstanding.erase(it);
        }
      }
    });
  }
  // Wait on acknowledgements (not time), then kill.
  const auto deadline = std::chrono::steady_clock::now() + 60s;
  while (acked_total < 400 && std::chrono::steady_clock::now() < deadline) std::this_thread::yield();
  server.kill9();
  stop = true;
  for (auto& t : threads) t.join();
  uint64_t max_seq = 0;
  for (uint64_t s : max_acked) max_seq = std::max(max_seq, s);
  ASSERT_GE(acked_total.load(), 400u);
  clients.clear();

  ServerProcess restarted;
  ASSERT_TRUE(restarted.start(dir, {"--tick-hz", "120"})) << restarted.log();
  client::TerrainClient c;
  ASSERT_TRUE(c.connect("127.0.0.1", restarted.port(), "checker").ok());
  const uint64_t recovered_seq = c.welcome().global_sequence;
  {
    // Edit at once: the restarted server must log and acknowledge (its ticks continue the
    // log's instead of starting again at 0, which the log refused: a crash loop).
    client::TerrainClient editor;
    ASSERT_TRUE(editor.connect("127.0.0.1", restarted.port(), "after-crash").ok());
    StampRng rng(seed + 1000);
    std::vector<uint32_t> seqs;
    for (int i = 0; i < 10; ++i) seqs.push_back(*editor.deform(random_stamp(rng, editor.welcome().world)));
    ASSERT_TRUE(editor.wait_until([&] { return editor.ack(seqs.back()).has_value(); }, 30s))
        << restarted.log();
    for (uint32_t s : seqs) {
      ASSERT_TRUE(editor.ack(s).has_value());
      EXPECT_TRUE(editor.ack(s)->accepted) << editor.ack(s)->field;
      EXPECT_GT(editor.ack(s)->global_seq, recovered_seq);
    }
    EXPECT_TRUE(restarted.running());
    EXPECT_EQ(restarted.log().find("event=fatal"), std::string::npos) << restarted.log();
  }
  const uint64_t edited_seq = recovered_seq + 10;
  EXPECT_GE(recovered_seq, max_seq) << "an acknowledged stamp was lost\n" << restarted.log();
  // The restarted server's tiles equal a replay of the log from the initial terrain.
  const World expected = replayed_world(dir, edited_seq);
  std::vector<TileCoord> tiles = c.all_coarse_tiles(0);
  const auto m1 = c.all_coarse_tiles(1);
  tiles.insert(tiles.end(), m1.begin(), m1.end());
  ASSERT_TRUE(c.subscribe(tiles).ok());
  EXPECT_TRUE(c.wait_until([&] { return c.store().held().size() == tiles.size(); }, 60s));
  EXPECT_TRUE(store_matches(c, expected));
  EXPECT_EQ(restarted.terminate(), 0) << restarted.log();
}

TEST(Recovery, KillNineDuringDeformStormKeepsEveryAcknowledgedStampAndEditsAtOnceAfterRestart) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    kill_during_storm(seed);
    if (HasFatalFailure()) return;
  }
}

TEST(Recovery, CleanShutdownWritesASnapshotThatRestartsWithoutReplay) {
  const std::string dir = temp_data_dir("clean");
  uint64_t seq = 0;
  {
    ServerProcess server;
    ASSERT_TRUE(server.start(dir, {"--tick-hz", "120"})) << server.log();
    client::TerrainClient c;
    ASSERT_TRUE(c.connect("127.0.0.1", server.port(), "one").ok());
    StampRng rng(5);
    std::vector<uint32_t> seqs;
    for (int i = 0; i < 30; ++i) seqs.push_back(*c.deform(random_stamp(rng, c.welcome().world)));
    ASSERT_TRUE(c.wait_until([&] { return c.ack(seqs.back()).has_value(); }, 30s));
    seq = c.ack(seqs.back())->global_seq;
    EXPECT_EQ(server.terminate(), 0) << server.log();
    EXPECT_TRUE(c.wait_until([&] { return c.bye().has_value(); }, 5s)) << "clients get Bye on shutdown";
    EXPECT_NE(server.log().find("event=snapshot"), std::string::npos) << server.log();
  }
  ServerProcess again;
  ASSERT_TRUE(again.start(dir)) << again.log();
  EXPECT_NE(again.log().find("replayed=0"), std::string::npos) << again.log();
  client::TerrainClient c;
  ASSERT_TRUE(c.connect("127.0.0.1", again.port(), "two").ok());
  EXPECT_EQ(c.welcome().global_sequence, seq);
  // Stats on request over the protocol.
  ASSERT_TRUE(c.connection().send(wire::StatsRequest{99}).ok());
  std::optional<wire::Stats> stats;
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!stats && std::chrono::steady_clock::now() < deadline) {
    auto m = c.connection().next(100ms);
    ASSERT_TRUE(m.ok());
    if (m->has_value()) {
      if (auto* st = std::get_if<wire::Stats>(&**m)) stats = *st;
    }
  }
  ASSERT_TRUE(stats.has_value());
  EXPECT_EQ(stats->request_id, 99u);
  EXPECT_EQ(stats->global_sequence, seq);
  EXPECT_EQ(stats->clients, 1u);
  EXPECT_GT(stats->bytes_out, 0u);
  EXPECT_EQ(again.terminate(), 0);
}

}  // namespace
}  // namespace loam::test

namespace loam::test {
namespace {

using namespace std::chrono_literals;

TEST(Session, ReconnectingClientResumesFromHeldVersionsAndConverges) {
  const std::string dir = temp_data_dir("resume");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--tick-hz", "60"})) << server.log();
  client::TerrainClient roamer, other;
  ASSERT_TRUE(roamer.connect("127.0.0.1", server.port(), "roamer").ok());
  ASSERT_TRUE(other.connect("127.0.0.1", server.port(), "other").ok());
  const auto tiles = roamer.all_coarse_tiles(0);
  ASSERT_TRUE(roamer.subscribe(tiles).ok());
  ASSERT_TRUE(roamer.wait_until([&] { return roamer.store().held().size() == tiles.size(); }, 30s));
  // Every tile is still at the initial terrain's version 0: since protocol 2 that is a held
  // version too, so the reconnect below must not send those tiles again.
  const uint64_t regions_before = roamer.store().counters().regions;
  roamer.connection().close();
  // While it is away: one stamp in the middle of tile (1, 1) only.
  StampParams p;
  p.kind = StampKind::kGaussian;
  p.center_x = (256 + 128) * other.welcome().world.meters_per_sample;
  p.center_y = (256 + 128) * other.welcome().world.meters_per_sample;
  p.radius = 10;
  p.intensity = 2;
  const uint32_t s = *other.deform(*validate_stamp(p, other.welcome().world));
  ASSERT_TRUE(other.wait_until([&] { return other.ack(s).has_value(); }, 10s));
  const uint64_t seq = other.ack(s)->global_seq;
  ASSERT_TRUE(roamer.reconnect("127.0.0.1", server.port()).ok());
  const World expected = replayed_world(dir, seq);
  EXPECT_TRUE(roamer.wait_until([&] { return bool(store_matches(roamer, expected)); }, 30s))
      << store_matches(roamer, expected).message();
  // Only the changed tile travelled again.
  EXPECT_EQ(roamer.store().counters().regions - regions_before, 1u);
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

// A reconnect that reaches another server of the same world (a fresh session behind the
// sequence this client saw) is refused before anything in flight is sent there.
TEST(Session, AReconnectToASessionBehindWhatTheClientSawIsRefused) {
  ServerProcess first, second;
  ASSERT_TRUE(first.start(temp_data_dir("resume_first"))) << first.log();
  ASSERT_TRUE(second.start(temp_data_dir("resume_second"))) << second.log();
  client::TerrainClient c;
  ASSERT_TRUE(c.connect("127.0.0.1", first.port(), "traveller").ok());
  StampParams p;
  p.kind = StampKind::kGaussian;
  p.center_x = 300 * c.welcome().world.meters_per_sample;
  p.center_y = 300 * c.welcome().world.meters_per_sample;
  p.radius = 10;
  p.intensity = 2;
  const uint32_t s = *c.deform(*validate_stamp(p, c.welcome().world));
  ASSERT_TRUE(c.wait_until([&] { return c.ack(s).has_value(); }, 10s));
  ASSERT_GT(c.last_seen_seq(), 0u);
  c.connection().close();
  const Status st = c.reconnect("127.0.0.1", second.port());
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().field, "welcome.global_sequence") << st.error().describe();
  // The session it left takes it back.
  const Status back = c.reconnect("127.0.0.1", first.port());
  EXPECT_TRUE(back.ok()) << back.error().describe();
  EXPECT_EQ(first.terminate(), 0) << first.log();
  EXPECT_EQ(second.terminate(), 0) << second.log();
}

// A client that holds only mip tiles (a viewer's far levels) follows per-sample stamps from
// their events alone, applying them at its mips (events at every mip); a shockwave's mips,
// which only mip 0 can simulate, come as patches of the changed samples over the version it
// holds. It converges on the server's tiles either way.
TEST(Session, MipTilesFollowStampsFromTheirEventsAndShockwavesAsPatches) {
  const std::string dir = temp_data_dir("partial");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--tick-hz", "60"})) << server.log();
  client::TerrainClient viewer, editor;
  ASSERT_TRUE(viewer.connect("127.0.0.1", server.port(), "viewer", wire::Role::kSpectator).ok());
  ASSERT_TRUE(editor.connect("127.0.0.1", server.port(), "editor").ok());
  std::vector<TileCoord> tiles = viewer.all_coarse_tiles(1);
  const auto top = viewer.all_coarse_tiles(2);
  tiles.insert(tiles.end(), top.begin(), top.end());
  ASSERT_TRUE(viewer.subscribe(tiles).ok());
  ASSERT_TRUE(viewer.wait_until([&] { return viewer.store().held().size() == tiles.size(); }, 30s));
  const WorldParams& w = editor.welcome().world;
  auto stamp = [&](StampKind kind, double x, double y, double r) {
    StampParams p;
    p.kind = kind;
    p.center_x = x, p.center_y = y, p.radius = r, p.intensity = 3;
    if (kind == StampKind::kCrater) p.shape = 0.3;
    if (kind == StampKind::kShockwave) p.steps = 30, p.speed = 0.5, p.damping = 0.02, p.intensity = 0.5;
    const uint32_t s = *editor.deform(*validate_stamp(p, w));
    EXPECT_TRUE(editor.wait_until([&] { return editor.ack(s).has_value(); }, 10s));
    return editor.ack(s)->global_seq;
  };
  const uint64_t region_bytes_before = viewer.connection().bytes_in_of(wire::MessageType::kRegionUpdate);
  const uint64_t event_bytes_before = viewer.connection().bytes_in_of(wire::MessageType::kDeformEvent);
  const uint64_t regions_before = viewer.store().counters().regions;
  uint64_t last = 0;
  for (int i = 0; i < 6; ++i) last = stamp(StampKind::kCrater, 300.0 + 250 * i, 400.0 + 150 * i, 12.0);
  World expected = replayed_world(dir, last);
  EXPECT_TRUE(viewer.wait_until([&] { return bool(store_matches(viewer, expected)); }, 30s))
      << store_matches(viewer, expected).message();
  EXPECT_EQ(viewer.store().counters().regions, regions_before) << "craters need no region at any mip";
  EXPECT_EQ(viewer.connection().bytes_in_of(wire::MessageType::kRegionUpdate), region_bytes_before);
  const uint64_t event_bytes =
      viewer.connection().bytes_in_of(wire::MessageType::kDeformEvent) - event_bytes_before;
  std::printf("6 craters: %llu event bytes at a mip-only viewer\n", (unsigned long long)event_bytes);
  EXPECT_LE(event_bytes, 6u * 64u);

  last = stamp(StampKind::kShockwave, 900.0, 700.0, 30.0);
  expected = replayed_world(dir, last);
  EXPECT_TRUE(viewer.wait_until([&] { return bool(store_matches(viewer, expected)); }, 30s))
      << store_matches(viewer, expected).message();
  EXPECT_GE(viewer.store().counters().regions_partial, 1u) << "the shockwave's mips come as patches";
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

// A client that receives another client's texture stamp fetches the image (StampImageRequest)
// and then applies the stamp itself, bit-exactly: its tiles match the server's, with no region
// sent for them.
TEST(Session, TextureStampEventsAreAppliedOnceTheirImageIsFetched) {
  const std::string dir = temp_data_dir("texfetch");
  const std::string png = dir + "/stamp.png";
  {
    auto w = load_default_terrain();
    ASSERT_TRUE(w.ok());
    ASSERT_TRUE(export_png16(w->world, {300, 200, 348, 240}, png).ok());
  }
  auto decoded = read_stamp_texture_file(png);
  ASSERT_TRUE(decoded.ok()) << decoded.error().describe();
  TextureRegistry reg;
  const uint64_t id = *reg.add(decoded->width, decoded->height, decoded->samples);
  ServerProcess server;
  ASSERT_TRUE(server.start(dir + "/data", {"--stamp-image", png, "--tick-hz", "60"})) << server.log();
  client::TerrainClient watcher, painter;
  ASSERT_TRUE(watcher.connect("127.0.0.1", server.port(), "watcher", wire::Role::kSpectator).ok());
  ASSERT_TRUE(painter.connect("127.0.0.1", server.port(), "painter").ok());
  const auto tiles = watcher.all_coarse_tiles(0);
  ASSERT_TRUE(watcher.subscribe(tiles).ok());
  ASSERT_TRUE(watcher.wait_until([&] { return watcher.store().held().size() == tiles.size(); }, 30s));
  const uint64_t regions_before = watcher.store().counters().regions;
  uint64_t last = 0;
  for (int i = 0; i < 3; ++i) {
    StampParams p;
    p.kind = StampKind::kTexture;
    p.center_x = 400 + 300 * i, p.center_y = 600, p.radius = 25, p.intensity = 2, p.rotation = 0.7 * i;
    p.texture_id = id;
    const uint32_t s = *painter.deform(*validate_stamp(p, painter.welcome().world, {}, &reg));
    ASSERT_TRUE(painter.wait_until([&] { return painter.ack(s).has_value(); }, 10s));
    ASSERT_TRUE(painter.ack(s)->accepted);
    last = painter.ack(s)->global_seq;
  }
  auto replayed = server::replay_log(server::list_segments(dir + "/data"), dir + "/data", last,
                                     gpu::BackendKind::kCpu, {png});
  ASSERT_TRUE(replayed.ok()) << replayed.error().describe();
  EXPECT_TRUE(watcher.wait_until([&] { return bool(store_matches(watcher, replayed->world)); }, 30s))
      << store_matches(watcher, replayed->world).message();
  EXPECT_EQ(watcher.textures().size(), 1u);
  EXPECT_EQ(watcher.store().counters().regions, regions_before) << "no tile had to be sent again";
  EXPECT_EQ(watcher.store().counters().events_applied, 3u);
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

// A tool panel lists the server's images (StampImageList) and gets each one to preview; the
// list is what the server registered, and the budget the server streams within comes in Stats.
TEST(Session, TheServerListsItsStampImagesAndEachArrivesForAPreview) {
  const std::string dir = temp_data_dir("texlist");
  std::vector<std::string> args = {"--client-budget", "65536"};
  std::set<uint64_t> ids;
  for (int i = 0; i < 2; ++i) {
    const std::string png = dir + "/stamp" + std::to_string(i) + ".png";
    auto w = load_default_terrain();
    ASSERT_TRUE(w.ok());
    ASSERT_TRUE(export_png16(w->world, {300 + 40 * i, 200, 348 + 40 * i, 240 + 8 * i}, png).ok());
    auto decoded = read_stamp_texture_file(png);
    ASSERT_TRUE(decoded.ok()) << decoded.error().describe();
    ids.insert(texture_content_id(decoded->width, decoded->height, decoded->samples));
    args.insert(args.end(), {"--stamp-image", png});
  }
  ServerProcess server;
  ASSERT_TRUE(server.start(dir + "/data", args)) << server.log();
  client::TerrainClient c;
  ASSERT_TRUE(c.connect("127.0.0.1", server.port(), "panel").ok());
  ASSERT_TRUE(c.request_stamp_images().ok());
  ASSERT_TRUE(c.request_stats().ok());
  ASSERT_TRUE(c.wait_until(
      [&] { return c.stamp_images().size() == 2 && c.textures().size() == 2 && c.server_stats(); }, 10s));
  std::set<uint64_t> listed;
  for (const wire::StampImageListEntry& e : c.stamp_images()) {
    listed.insert(e.image_id);
    const StampTexture* t = c.textures().find(e.image_id);
    ASSERT_NE(t, nullptr);
    EXPECT_EQ(uint32_t(t->width), e.width);
    EXPECT_EQ(uint32_t(t->height), e.height);
  }
  EXPECT_EQ(listed, ids);
  EXPECT_EQ(c.server_stats()->client_bytes_per_second, 65536u);
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

TEST(Recovery, TextureStampImagesAreStoredWithTheSnapshot) {
  const std::string dir = temp_data_dir("tex");
  // A 32x32 grayscale PNG: a region of the default terrain, written by the exporter.
  const std::string png = dir + "/stamp.png";
  {
    auto w = load_default_terrain();
    ASSERT_TRUE(w.ok());
    ASSERT_TRUE(export_png16(w->world, {100, 100, 132, 132}, png).ok());
  }
  auto decoded = read_stamp_texture_file(png);
  ASSERT_TRUE(decoded.ok()) << decoded.error().describe();
  const uint64_t id = texture_content_id(decoded->width, decoded->height, decoded->samples);
  auto texture_stamp = [&](const WorldParams& w) {
    TextureRegistry reg;
    EXPECT_TRUE(reg.add(decoded->width, decoded->height, decoded->samples).ok());
    StampParams p;
    p.kind = StampKind::kTexture;
    p.center_x = 500;
    p.center_y = 500;
    p.radius = 20;
    p.intensity = 3;
    p.texture_id = id;
    auto q = validate_stamp(p, w, {}, &reg);
    EXPECT_TRUE(q.ok()) << q.error().describe();
    return *q;
  };
  {
    ServerProcess server;
    ASSERT_TRUE(server.start(dir + "/data", {"--stamp-image", png})) << server.log();
    client::TerrainClient c;
    ASSERT_TRUE(c.connect("127.0.0.1", server.port(), "painter").ok());
    const uint32_t s = *c.deform(texture_stamp(c.welcome().world));
    ASSERT_TRUE(c.wait_until([&] { return c.ack(s).has_value(); }, 10s));
    EXPECT_TRUE(c.ack(s)->accepted) << c.ack(s)->field;
    EXPECT_EQ(server.terminate(), 0) << server.log();
  }
  // Restarted without --stamp-image: the snapshot brings the image back.
  ServerProcess again;
  ASSERT_TRUE(again.start(dir + "/data")) << again.log();
  client::TerrainClient c;
  ASSERT_TRUE(c.connect("127.0.0.1", again.port(), "painter2").ok());
  const uint32_t s = *c.deform(texture_stamp(c.welcome().world));
  ASSERT_TRUE(c.wait_until([&] { return c.ack(s).has_value(); }, 10s));
  EXPECT_TRUE(c.ack(s)->accepted) << c.ack(s)->field << "\n" << again.log();
  ASSERT_TRUE(c.connection().send(wire::StampImageRequest{id}).ok());
  std::optional<wire::StampImageResponse> image;
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!image && std::chrono::steady_clock::now() < deadline) {
    auto m = c.connection().next(100ms);
    ASSERT_TRUE(m.ok());
    if (m->has_value()) {
      if (auto* r = std::get_if<wire::StampImageResponse>(&**m)) image = *r;
    }
  }
  ASSERT_TRUE(image.has_value());
  EXPECT_TRUE(image->found);
  EXPECT_EQ(image->width, 32);
  const uint64_t last = c.ack(s)->global_seq;
  EXPECT_EQ(again.terminate(), 0);
  // Replay of the log finds the image in the data folder (no --stamp-image needed), and
  // applies both texture stamps.
  auto replayed = server::replay_log(server::list_segments(dir + "/data"), dir + "/data", last);
  ASSERT_TRUE(replayed.ok()) << replayed.error().describe();
  EXPECT_EQ(replayed->last_seq, last);
}

}  // namespace
}  // namespace loam::test
