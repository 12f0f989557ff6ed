// A session on the refined default world (`loam-server serve --terrain refined`): 131 x 98 km
// at 1 m, generated on demand. The server starts without building the world, serves edits to
// a client that holds a few tiles, snapshots only what was edited, recovers from the snapshot
// after a kill, and `replay` rebuilds the same world from the log alone.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <vector>

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

}  // namespace
}  // namespace loam::test
