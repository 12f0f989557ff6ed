// A session on the refined default world (`loam-server serve --terrain refined`): 131 x 98 km
// at 1 m, generated on demand. The server starts without building the world, serves edits to
// a client that holds a few tiles, snapshots only what was edited, recovers from the snapshot
// after a kill, and `replay` rebuilds the same world from the log alone.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <vector>

#include "dem/refined_default.h"
#include "protocol/snapshot/snapshot.h"
#include "tests/integration/integration_util.h"
#include "tests/integration/server_process.h"

namespace loam::test {
namespace {

using namespace std::chrono_literals;

QuantizedStamp stamp_at(const WorldParams& w, StampKind kind, double x, double y, double radius,
                        double intensity) {
  StampParams p;
  p.kind = kind;
  p.center_x = x * w.meters_per_sample;
  p.center_y = y * w.meters_per_sample;
  p.radius = radius * w.meters_per_sample;
  p.intensity = intensity;
  auto q = validate_stamp(p, w, StampLimits{});
  EXPECT_TRUE(q.ok()) << q.error().describe();
  return q.ok() ? *q : QuantizedStamp{};
}

std::string server_binary_output(const std::string& args) {
  const std::string cmd = std::string(LOAM_SERVER_BINARY) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  std::string out;
  if (!p) return out;
  char buf[512];
  while (fgets(buf, sizeof buf, p)) out += buf;
  out += "exit " + std::to_string(pclose(p));
  return out;
}

TEST(RefinedSession, ServesEditsSnapshotsOnlyEditedTilesRecoversAndReplays) {
  const std::string dir = temp_data_dir("refined");
  uint64_t last = 0;
  std::vector<TileCoord> tiles = {{Layer::kCoarse, 0, 200, 100},
                                  {Layer::kCoarse, 0, 201, 100},
                                  {Layer::kCoarse, 0, 200, 101},
                                  {Layer::kCoarse, 0, 201, 101},
                                  {Layer::kCoarse, 9, 0, 0}};
  {
    ServerProcess server;
    ASSERT_TRUE(server.start(dir, {"--terrain", "refined", "--snapshot-every", "3", "--cache-mb", "8"}))
        << server.log();
    EXPECT_NE(server.log().find("world_tiles=512x384"), std::string::npos) << server.log();
    client::TerrainClient c;
    ASSERT_TRUE(c.connect("127.0.0.1", server.port(), "refined").ok());
    const WorldParams& w = c.welcome().world;
    ASSERT_EQ(w.tiles_x, 512);
    ASSERT_TRUE(c.subscribe(tiles).ok());
    ASSERT_TRUE(c.wait_until([&] { return c.store().held().size() == tiles.size(); }, 60s));
    // Stamps around the four-tile corner at (201, 101).
    const double cx = 201 * 256, cy = 101 * 256;
    std::vector<uint32_t> seqs;
    seqs.push_back(*c.deform(stamp_at(w, StampKind::kCrater, cx, cy, 40, -3)));
    seqs.push_back(*c.deform(stamp_at(w, StampKind::kGaussian, cx - 60, cy + 30, 25, 2)));
    seqs.push_back(*c.deform(stamp_at(w, StampKind::kGaussian, cx + 70, cy - 50, 30, -1.5)));
    seqs.push_back(*c.deform(stamp_at(w, StampKind::kCrater, cx + 10, cy + 90, 20, 1)));
    ASSERT_TRUE(c.wait_until([&] { return c.ack(seqs.back()).has_value(); }, 30s));
    for (uint32_t s : seqs) {
      ASSERT_TRUE(c.ack(s) && c.ack(s)->accepted);
      last = std::max(last, c.ack(s)->global_seq);
    }
    const World expected = replayed_world(dir, last);
    EXPECT_TRUE(c.wait_until([&] { return bool(store_matches(c, expected)); }, 30s))
        << store_matches(c, expected);
    EXPECT_LE(expected.edited_coarse_tile_count(), 4u + 12u) << "edits stay near the stamps at every mip";
    server.kill9();
  }
  // The snapshot after the third stamp holds the edited mip-0 tiles only, and names its base.
  const auto snaps = list_snapshots(dir);
  ASSERT_EQ(snaps.size(), 1u);
  auto manifest = read_snapshot_manifest(snaps[0]);
  ASSERT_TRUE(manifest.ok()) << manifest.error().describe();
  EXPECT_LE(manifest->coarse_tiles, 4u);
  EXPECT_NE(manifest->base_description.find("refined"), std::string::npos) << manifest->base_description;
  // Recovery from the snapshot plus the log's last stamp.
  ServerProcess restarted;
  ASSERT_TRUE(restarted.start(dir)) << restarted.log();
  EXPECT_NE(restarted.log().find("snapshot=" + snaps[0]), std::string::npos) << restarted.log();
  client::TerrainClient c;
  ASSERT_TRUE(c.connect("127.0.0.1", restarted.port(), "after").ok());
  EXPECT_EQ(c.welcome().global_sequence, last);
  ASSERT_TRUE(c.subscribe(tiles).ok());
  ASSERT_TRUE(c.wait_until([&] { return c.store().held().size() == tiles.size(); }, 60s));
  const World expected = replayed_world(dir, last);
  EXPECT_TRUE(store_matches(c, expected));
  EXPECT_EQ(restarted.terminate(), 0) << restarted.log();
  // Replay from the log alone rebuilds the refined world and reaches the same hash.
  char hash[20];
  std::snprintf(hash, sizeof hash, "%016llx", (unsigned long long)expected.world_hash());
  const std::string out = server_binary_output("replay " + dir);
  EXPECT_NE(out.find(std::string("world hash ") + hash), std::string::npos) << out;
  EXPECT_NE(out.find("exit 0"), std::string::npos) << out;
}

TEST(RefinedSession, AClientThatGeneratesTheBaseDownloadsOnlyEditedTilesAndConverges) {
  const std::string dir = temp_data_dir("generates");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--terrain", "refined"})) << server.log();
  const std::vector<TileCoord> tiles = {{Layer::kCoarse, 0, 300, 200},
                                        {Layer::kCoarse, 0, 301, 200},
                                        {Layer::kCoarse, 1, 150, 100},
                                        {Layer::kCoarse, 4, 18, 12},
                                        {Layer::kCoarse, 9, 0, 0}};
  client::TerrainClient c;
  c.set_base_provider(generate_known_base);
  ASSERT_TRUE(c.connect("127.0.0.1", server.port(), "generates").ok());
  ASSERT_NE(c.welcome().base_identity, 0u);
  ASSERT_NE(c.base(), nullptr);
  ASSERT_TRUE(c.subscribe(tiles).ok());
  // Held at once, at version 0, without a region from the server.
  EXPECT_EQ(c.store().held().size(), tiles.size());
  EXPECT_EQ(c.tiles_generated(), tiles.size());
  // A client without the base downloads the same tiles; both hold the same samples.
  client::TerrainClient d;
  ASSERT_TRUE(d.connect("127.0.0.1", server.port(), "downloads").ok());
  EXPECT_EQ(d.base(), nullptr);
  ASSERT_TRUE(d.subscribe(tiles).ok());
  ASSERT_TRUE(d.wait_until([&] { return d.store().held().size() == tiles.size(); }, 60s));
  EXPECT_GE(d.region_chunks_received(), tiles.size());
  for (const TileCoord& t : tiles) EXPECT_EQ(c.store().hash(t), d.store().hash(t)) << to_string(t);
  // Stamps on the held tiles reach the generating client as events, not regions.
  const WorldParams& w = c.welcome().world;
  std::vector<uint32_t> seqs;
  seqs.push_back(*c.deform(stamp_at(w, StampKind::kCrater, 301 * 256, 200 * 256 + 100, 40, -3)));
  seqs.push_back(*c.deform(stamp_at(w, StampKind::kGaussian, 300 * 256 + 50, 200 * 256 + 60, 25, 2)));
  ASSERT_TRUE(c.wait_until([&] { return c.ack(seqs.back()).has_value(); }, 30s));
  const uint64_t last = c.ack(seqs.back())->global_seq;
  const World expected = replayed_world(dir, last);
  EXPECT_TRUE(c.wait_until([&] { return bool(store_matches(c, expected)); }, 30s))
      << store_matches(c, expected);
  EXPECT_TRUE(d.wait_until([&] { return bool(store_matches(d, expected)); }, 30s))
      << store_matches(d, expected);
  EXPECT_EQ(c.region_chunks_received(), 0u);
  EXPECT_EQ(c.hash_mismatches(), 0u);
  // A later subscriber to an edited tile gets it from the server (only edits travel).
  client::TerrainClient late;
  late.set_base_provider(generate_known_base);
  ASSERT_TRUE(late.connect("127.0.0.1", server.port(), "late").ok());
  ASSERT_TRUE(late.subscribe({{Layer::kCoarse, 0, 301, 200}, {Layer::kCoarse, 0, 100, 100}}).ok());
  EXPECT_TRUE(late.wait_until(
      [&] { return bool(store_matches(late, expected)) && late.region_chunks_received() > 0; }, 30s))
      << store_matches(late, expected);
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

TEST(RefinedSession, ACropSessionNamesNoBaseSoClientsDownloadVersionZero) {
  const std::string dir = temp_data_dir("crop");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir)) << server.log();
  // Even once a stamp has changed every tile (the bug this pins: version 0 was then taken for
  // the fill base, and clients generated zeros where the crop's samples were).
  client::TerrainClient editor;
  ASSERT_TRUE(editor.connect("127.0.0.1", server.port(), "editor").ok());
  const WorldParams& w = editor.welcome().world;
  const RectI r = w.sample_rect();
  const uint32_t s =
      *editor.deform(stamp_at(w, StampKind::kGaussian, double(r.x1) / 2, double(r.y1) / 2, 2000, 1));
  ASSERT_TRUE(editor.wait_until([&] { return editor.ack(s).has_value(); }, 30s));
  ASSERT_TRUE(editor.ack(s)->accepted);
  client::TerrainClient c;
  c.set_base_provider(generate_known_base);
  ASSERT_TRUE(c.connect("127.0.0.1", server.port(), "crop").ok());
  EXPECT_EQ(c.welcome().base_identity, 0u) << "the crop's samples are edits at version 0 over a fill";
  EXPECT_EQ(c.base(), nullptr);
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

}  // namespace
}  // namespace loam::test
