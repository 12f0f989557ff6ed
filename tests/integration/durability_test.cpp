// Durability: what a crash, a restart with other options, damaged files and a full disk must
// not do to a session (lose an acknowledged stamp, stop the server, or report a wrong hash).
#include <gtest/gtest.h>
#include <sys/mount.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "dem/default_terrain.h"
#include "dem/dem_export.h"
#include "protocol/hex64.h"
#include "protocol/log/log_file.h"
#include "protocol/snapshot/snapshot.h"
#include "server/storage.h"
#include "server/terrain_source.h"
#include "tests/integration/integration_util.h"
#include "tests/integration/server_process.h"

namespace loam::test {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

// A gaussian of `radius_samples` at the world's centre (radius in samples: the limit's unit).
QuantizedStamp wide_gaussian(const WorldParams& w, double radius_samples, const StampLimits& limits) {
  StampParams p;
  p.kind = StampKind::kGaussian;
  const RectI r = w.sample_rect();
  p.center_x = double(r.x0 + r.x1) / 2 * w.meters_per_sample;
  p.center_y = double(r.y0 + r.y1) / 2 * w.meters_per_sample;
  p.radius = radius_samples * w.meters_per_sample;
  p.intensity = 5;
  auto q = validate_stamp(p, w, limits);
  EXPECT_TRUE(q.ok()) << q.error().describe();
  return q.ok() ? *q : QuantizedStamp{};
}

struct Exit {
  int code = -1;
  std::string out;
};
Exit run(const std::string& args) {
  const std::string cmd = std::string(LOAM_SERVER_BINARY) + " " + args + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  Exit e;
  if (!p) return e;
  char buf[512];
  while (fgets(buf, sizeof buf, p)) e.out += buf;
  const int status = pclose(p);
  e.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return e;
}

// Deforms `n` random stamps and waits for every ack; returns the last global sequence.
uint64_t deform_all(client::TerrainClient& c, int n, uint32_t seed) {
  StampRng rng(seed);
  std::vector<uint32_t> seqs;
  for (int i = 0; i < n; ++i) seqs.push_back(*c.deform(random_stamp(rng, c.welcome().world)));
  EXPECT_TRUE(c.wait_until([&] { return c.ack(seqs.back()).has_value(); }, 30s));
  uint64_t last = 0;
  for (uint32_t s : seqs) {
    const auto a = c.ack(s);
    EXPECT_TRUE(a && a->accepted) << (a ? a->field : "no ack");
    if (a) last = std::max(last, a->global_seq);
  }
  return last;
}

TEST(Durability, RestartWithOtherLimitsReproducesTheLoggedWorld) {
  const std::string dir = temp_data_dir("limits");
  const StampLimits wide{65536.0, 1024, int64_t(1) << 24};
  uint64_t seq = 0;
  {
    ServerProcess server;
    ASSERT_TRUE(server.start(dir, {"--max-radius", "65536"})) << server.log();
    client::TerrainClient c;
    ASSERT_TRUE(c.connect("127.0.0.1", server.port(), "wide").ok());
    const uint32_t s = *c.deform(wide_gaussian(c.welcome().world, 5000, wide));
    ASSERT_TRUE(c.wait_until([&] { return c.ack(s).has_value(); }, 10s));
    ASSERT_TRUE(c.ack(s)->accepted) << c.ack(s)->field;
    seq = c.ack(s)->global_seq;
    server.kill9();  // no snapshot: the log alone holds the stamp
  }
  const World expected = replayed_world(dir, seq);
  {
    auto initial = server::load_initial_terrain("", nullptr);
    ASSERT_TRUE(initial.ok());
    ASSERT_NE(expected.world_hash(), initial->world_hash()) << "the wide stamp changed nothing";
  }
  ServerProcess restarted;
  ASSERT_TRUE(restarted.start(dir)) << restarted.log();  // default limits: max radius 4096
  EXPECT_NE(restarted.log().find("event=limits_recorded"), std::string::npos) << restarted.log();
  client::TerrainClient c;
  ASSERT_TRUE(c.connect("127.0.0.1", restarted.port(), "after").ok());
  EXPECT_EQ(c.welcome().global_sequence, seq);
  std::vector<TileCoord> tiles = c.all_coarse_tiles(0);
  ASSERT_TRUE(c.subscribe(tiles).ok());
  ASSERT_TRUE(c.wait_until([&] { return c.store().held().size() == tiles.size(); }, 30s));
  EXPECT_TRUE(store_matches(c, expected)) << restarted.log();
  // New stamps are checked against the new limits.
  const uint32_t s = *c.deform(wide_gaussian(c.welcome().world, 5000, wide));
  ASSERT_TRUE(c.wait_until([&] { return c.ack(s).has_value(); }, 10s));
  EXPECT_FALSE(c.ack(s)->accepted);
  const uint64_t small = deform_all(c, 3, 7);
  EXPECT_EQ(small, seq + 3);
  EXPECT_EQ(restarted.terminate(), 0) << restarted.log();
  // Replay from the initial terrain across both segments, each under its own limits.
  const Exit r = run("replay " + dir);
  EXPECT_EQ(r.code, 0) << r.out;
  ServerProcess again;  // and a third start with the wide limits again
  ASSERT_TRUE(again.start(dir, {"--max-radius", "65536"})) << again.log();
  client::TerrainClient c3;
  ASSERT_TRUE(c3.connect("127.0.0.1", again.port(), "third").ok());
  EXPECT_EQ(c3.welcome().global_sequence, seq + 3);
  EXPECT_EQ(again.terminate(), 0) << again.log();
}

TEST(Durability, LoggedRecordThatFailsToApplyStopsRecoveryNamingIt) {
  const std::string dir = temp_data_dir("fails");
  fs::create_directories(dir + "/log");
  log::InitialTerrain initial;
  auto world = server::load_initial_terrain("", &initial);
  ASSERT_TRUE(world.ok());
  log::SegmentHeader h;
  h.world = world->params();
  h.initial = initial;
  h.base_world_hash = initial.world_hash;
  auto w = log::LogWriter::create(dir + "/log/" + log::segment_file_name(0), h);
  ASSERT_TRUE(w.ok()) << w.error().describe();
  // A texture stamp whose image the session never stored: it cannot mean anything.
  QuantizedStamp q = wide_gaussian(world->params(), 10, {});
  q.kind = StampKind::kTexture;
  q.texture_id = 0x1234567890abcdefull;
  ASSERT_TRUE(w->append({1, 1, 7, q}).ok());
  ASSERT_TRUE(w->sync().ok());
  auto opened = server::open_storage(dir, "", {});
  ASSERT_FALSE(opened.ok()) << "a record that fails to apply must not be skipped";
  EXPECT_NE(opened.error().message.find("record 1"), std::string::npos) << opened.error().describe();
  EXPECT_NE(opened.error().message.find("fails to apply"), std::string::npos) << opened.error().describe();
  auto replayed = server::replay_log(server::list_segments(dir), dir);
  ASSERT_FALSE(replayed.ok());
  EXPECT_NE(replayed.error().message.find("record 1"), std::string::npos) << replayed.error().describe();
}

// Writes 60 stamps with a snapshot every 20, stops cleanly, then damages segment 0 in the middle.
std::string session_with_snapshots(const std::string& tag, uint64_t* last) {
  const std::string dir = temp_data_dir(tag);
  ServerProcess server;
  EXPECT_TRUE(server.start(dir, {"--snapshot-every", "20", "--tick-hz", "120"})) << server.log();
  client::TerrainClient c;
  EXPECT_TRUE(c.connect("127.0.0.1", server.port(), "snap").ok());
  uint64_t seq = 0;
  for (int round = 0; round < 6; ++round) seq = deform_all(c, 10, uint32_t(round + 1));
  EXPECT_EQ(server.terminate(), 0) << server.log();
  *last = seq;
  return dir;
}

void flip_byte(const std::string& path, size_t offset) {
  std::fstream f(path, std::ios::in | std::ios::out | std::ios::binary);
  f.seekg(std::streamoff(offset));
  char b = 0;
  f.read(&b, 1);
  b = char(b ^ 0x5a);
  f.seekp(std::streamoff(offset));
  f.write(&b, 1);
}

TEST(Durability, DamagedOldSegmentCoveredByASnapshotDoesNotBlockStartup) {
  uint64_t last = 0;
  const std::string dir = session_with_snapshots("oldseg", &last);
  const auto segs = server::list_segments(dir);
  ASSERT_GE(segs.size(), 3u);
  flip_byte(segs[0], fs::file_size(segs[0]) / 2);  // mid-file damage in the oldest segment
  ServerProcess server;
  ASSERT_TRUE(server.start(dir)) << server.log();
  EXPECT_NE(server.log().find("event=older_segment_damaged"), std::string::npos) << server.log();
  client::TerrainClient c;
  ASSERT_TRUE(c.connect("127.0.0.1", server.port(), "after").ok());
  EXPECT_EQ(c.welcome().global_sequence, last);
  EXPECT_EQ(deform_all(c, 2, 99), last + 2);
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

// The server's terrain memory follows --cache-mb: edited tiles a snapshot holds are evicted and
// read back from the store. With a cache of one tile and a snapshot at every 64 KiB of dirty
// tiles, a session evicts and reloads edited tiles all the time; it must serve the replayed
// world before and after a restart, and retention must leave only the kept snapshots and
// the log they need, from which `replay` still reproduces the world.
TEST(Durability, EditedTilesEvictedToIncrementalSnapshotsServeTheLoggedWorldAcrossARestart) {
  const std::string dir = temp_data_dir("evict");
  const std::vector<std::string> opts = {"--cache-mb",         "1",  "--snapshot-dirty-mb", "0",
                                         "--snapshot-every",   "15", "--keep-snapshots",    "2",
                                         "--log-retention-mb", "0",  "--tick-hz",           "120"};
  uint64_t last = 0;
  {
    ServerProcess server;
    ASSERT_TRUE(server.start(dir, opts)) << server.log();
    client::TerrainClient c;
    ASSERT_TRUE(c.connect("127.0.0.1", server.port(), "evict").ok());
    for (uint32_t round = 0; round < 6; ++round) last = deform_all(c, 10, 300 + round);
    EXPECT_EQ(server.terminate(), 0) << server.log();
    EXPECT_NE(server.log().find("event=snapshot "), std::string::npos) << server.log();
  }
  // Retention: two snapshots, and no segment older than the older one's.
  EXPECT_EQ(list_snapshots(dir).size(), 2u);
  const auto segs = server::list_segments(dir);
  ASSERT_FALSE(segs.empty());
  EXPECT_EQ(segs.front().find("segment-00000000"), std::string::npos) << "segment 0 is pruned";
  const Exit replay = run("replay " + dir);
  ASSERT_EQ(replay.code, 0) << replay.out;
  auto snap = read_snapshot_manifest(list_snapshots(dir).front());
  ASSERT_TRUE(snap.ok());
  EXPECT_NE(replay.out.find(hex64(snap->world_hash)), std::string::npos)
      << "replay from the kept snapshot reproduces the newest one: " << replay.out;

  ServerProcess restarted;
  ASSERT_TRUE(restarted.start(dir, opts)) << restarted.log();
  EXPECT_NE(restarted.log().find("snapshot=" + list_snapshots(dir).front()), std::string::npos)
      << restarted.log();
  client::TerrainClient c;
  ASSERT_TRUE(c.connect("127.0.0.1", restarted.port(), "after").ok());
  EXPECT_EQ(c.welcome().global_sequence, last);
  std::vector<TileCoord> tiles = c.all_coarse_tiles(0);
  ASSERT_TRUE(c.subscribe(tiles).ok());
  ASSERT_TRUE(c.wait_until([&] { return c.store().held().size() == tiles.size(); }, 30s));
  auto loaded = read_snapshot(list_snapshots(dir).front());
  ASSERT_TRUE(loaded.ok()) << loaded.error().describe();
  EXPECT_TRUE(store_matches(c, loaded->world)) << restarted.log();
  EXPECT_EQ(deform_all(c, 5, 77), last + 5);
  EXPECT_EQ(restarted.terminate(), 0) << restarted.log();
}

TEST(Durability, ReplayAndLogToolsExitNonZeroOnADamagedLogUnlessAllowed) {
  uint64_t last = 0;
  const std::string dir = session_with_snapshots("tools", &last);
  const auto segs = server::list_segments(dir);
  // Damage the middle of the second segment: records after it cannot be read.
  flip_byte(segs[1], fs::file_size(segs[1]) / 2);
  const Exit replay = run("replay " + dir);
  EXPECT_EQ(replay.code, 3) << replay.out;
  EXPECT_EQ(replay.out.find("world hash"), std::string::npos)
      << "no hash from a partial read: " << replay.out;
  const Exit allowed = run("replay " + dir + " --allow-damaged");
  EXPECT_EQ(allowed.code, 0) << allowed.out;
  EXPECT_NE(allowed.out.find("ignored damaged tail"), std::string::npos) << allowed.out;
  const Exit summary = run("log summary " + dir);
  EXPECT_EQ(summary.code, 3) << summary.out;
  EXPECT_NE(summary.out.find("damaged"), std::string::npos) << summary.out;
  EXPECT_EQ(run("log summary " + dir + " --allow-damaged").code, 0);
  EXPECT_EQ(run("log dump " + segs[1]).code, 3);
}

TEST(Durability, MediaDamagedLastRecordStopsStartupUntilAnOperatorRepairs) {
  const std::string dir = temp_data_dir("media");
  uint64_t seq = 0;
  {
    ServerProcess server;
    ASSERT_TRUE(server.start(dir)) << server.log();
    client::TerrainClient c;
    ASSERT_TRUE(c.connect("127.0.0.1", server.port(), "m").ok());
    seq = deform_all(c, 5, 3);
    server.kill9();
  }
  const std::string seg = server::list_segments(dir).back();
  const uint64_t size = fs::file_size(seg);
  flip_byte(seg, size - 20);  // inside the last, complete, acknowledged record
  ServerProcess server;
  EXPECT_FALSE(server.start(dir, {}, 20s)) << "a complete acknowledged record must not be dropped silently";
  EXPECT_NE(server.log().find("log repair"), std::string::npos) << server.log();
  EXPECT_EQ(fs::file_size(seg), size);
  const size_t at = size - (log::kRecordOverheadBytes + log::kStampRecordBodyBytes);
  EXPECT_NE(run("log repair " + dir + " --at 1").code, 0) << "the offset confirms what is dropped";
  const Exit repaired = run("log repair " + dir + " --at " + std::to_string(at));
  EXPECT_EQ(repaired.code, 0) << repaired.out;
  ServerProcess again;
  ASSERT_TRUE(again.start(dir)) << again.log();
  client::TerrainClient c;
  ASSERT_TRUE(c.connect("127.0.0.1", again.port(), "m2").ok());
  EXPECT_EQ(c.welcome().global_sequence, seq - 1);
  EXPECT_EQ(again.terminate(), 0);
}

TEST(Durability, SegmentWithAnIncompleteHeaderFromACrashDuringItsCreationIsRemoved) {
  uint64_t last = 0;
  const std::string dir = session_with_snapshots("torn-header", &last);
  const auto segs = server::list_segments(dir);
  const std::string next = dir + "/log/" + log::segment_file_name(uint32_t(segs.size()));
  std::ofstream(next, std::ios::binary).write("LOAMLOG\n\x10", 9);
  auto opened = server::open_storage(dir, "", {});
  ASSERT_TRUE(opened.ok()) << opened.error().describe();
  EXPECT_EQ(opened->terrain.last_seq(), last);
  EXPECT_FALSE(fs::exists(next));
  EXPECT_NE(opened->report.damage.find("header incomplete"), std::string::npos) << opened->report.damage;
}

TEST(Durability, ExportReadsTheSessionWithoutChangingTheDataFolder) {
  uint64_t last = 0;
  const std::string dir = session_with_snapshots("export", &last);
  const auto before = server::list_segments(dir);
  const Exit e = run("export " + dir + " " + dir + "/out.png");
  EXPECT_EQ(e.code, 0) << e.out;
  EXPECT_NE(e.out.find("sequence " + std::to_string(last)), std::string::npos) << e.out;
  EXPECT_EQ(server::list_segments(dir), before);
}

// A DEM whose sidecar changed after the session began would re-import at another scale: replay
// must refuse, naming the parameter, rather than report the hash of another world.
TEST(Durability, ReplayRefusesADemThatNowImportsAtAnotherScale) {
  const std::string dir = temp_data_dir("dem");
  const std::string png = default_terrain_png(dir);
  ASSERT_FALSE(::testing::Test::HasFailure());
  {
    ServerProcess server;
    ASSERT_TRUE(server.start(dir + "/data", {"--dem", png})) << server.log();
    client::TerrainClient c;
    ASSERT_TRUE(c.connect("127.0.0.1", server.port(), "dem").ok());
    deform_all(c, 3, 11);
    EXPECT_EQ(server.terminate(), 0) << server.log();
  }
  EXPECT_EQ(run("replay " + dir + "/data").code, 0);
  const std::string sidecar = dir + "/terrain.json";
  std::stringstream text;
  text << std::ifstream(sidecar).rdbuf();
  nlohmann::json j = nlohmann::json::parse(text.str());
  j["loam_world"]["meters_per_sample"] = j["loam_world"]["meters_per_sample"].get<double>() * 2;
  j["meters_per_sample_xy"] = {j["loam_world"]["meters_per_sample"], j["loam_world"]["meters_per_sample"]};
  std::ofstream(sidecar, std::ios::trunc) << j.dump(1);
  const Exit r = run("replay " + dir + "/data");
  EXPECT_NE(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("meters_per_sample"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("world hash"), std::string::npos) << r.out;
}

// --- A full disk: a small tmpfs mounted for the test ---

class FullDisk : public ::testing::Test {
 protected:
  void SetUp() override {
    mount_ = temp_data_dir("mnt");
    if (::mount("loam-test", mount_.c_str(), "tmpfs", 0, "size=8m") != 0) {
      const int err = errno;
      mounted_ = false;
      // CI runs as root where mounting works: there a refused mount is a failure, not a skip.
      const char* ci = std::getenv("CI");
      if ((err == EPERM || err == EACCES) && !(ci && std::string(ci) == "true")) {
        GTEST_SKIP() << "cannot mount a tmpfs here (" << std::strerror(err)
                     << "): the full-disk test needs CAP_SYS_ADMIN (root, or its own mount namespace)";
      }
      FAIL() << "mount tmpfs: " << std::strerror(err);
    }
    mounted_ = true;
  }
  void TearDown() override {
    if (mounted_) ::umount2(mount_.c_str(), MNT_DETACH);
    fs::remove_all(mount_);
  }
  // Fills the file system to the last byte with a filler file.
  void fill() {
    std::ofstream f(mount_ + "/filler", std::ios::binary);
    std::vector<char> block(64 * 1024, 'x');
    while (f.write(block.data(), std::streamsize(block.size()))) {
    }
    f.close();
    std::ofstream small(mount_ + "/filler2", std::ios::binary);
    while (small.put('x')) small.flush();
  }
  void make_room() {
    fs::remove(mount_ + "/filler");
    fs::remove(mount_ + "/filler2");
  }
  std::string mount_;
  bool mounted_ = false;
};

TEST_F(FullDisk, FullDiskRefusesEditsKeepsServingAndRecoversWhenSpaceReturns) {
  const std::string dir = mount_ + "/data";
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--tick-hz", "60", "--snapshot-every", "5", "--hashes-every", "30",
                                 "--deforms-per-second", "1000", "--deform-burst", "1000"}))
      << server.log();
  client::TerrainClient c;
  ASSERT_TRUE(c.connect("127.0.0.1", server.port(), "full").ok());
  uint64_t seq = deform_all(c, 6, 1);  // a snapshot is taken on the way
  // Acks leave before the tick applies and snapshots: wait for the snapshot's line.
  const auto snapshotted = std::chrono::steady_clock::now() + 20s;
  while (server.log().find("event=snapshot ") == std::string::npos &&
         std::chrono::steady_clock::now() < snapshotted)
    std::this_thread::sleep_for(20ms);
  ASSERT_NE(server.log().find("event=snapshot "), std::string::npos) << server.log();
  ASSERT_TRUE(c.subscribe(c.all_coarse_tiles(0)).ok());
  fill();
  // Edits are refused with a clear reason; nothing refused is logged or applied.
  StampRng rng(5);
  int refused = 0;
  for (int i = 0; i < 400 && refused == 0; ++i) {  // the last page of the segment may still take records
    const uint32_t s = *c.deform(random_stamp(rng, c.welcome().world));
    ASSERT_TRUE(c.wait_until([&] { return c.ack(s).has_value(); }, 10s)) << server.log();
    if (c.ack(s)->accepted) {
      seq = c.ack(s)->global_seq;  // a page of the log still had room
      continue;
    }
    EXPECT_EQ(c.ack(s)->code, wire::WireErrorCode::kIo);
    EXPECT_EQ(c.ack(s)->field, "storage.unavailable");
    ++refused;
  }
  ASSERT_GT(refused, 0) << server.log();
  EXPECT_TRUE(server.running()) << server.log();
  EXPECT_NE(server.log().find("event=storage_unavailable"), std::string::npos) << server.log();
  // Still serving: a new viewer joins and receives tiles and hashes.
  client::TerrainClient viewer;
  ASSERT_TRUE(viewer.connect("127.0.0.1", server.port(), "viewer", wire::Role::kSpectator).ok());
  EXPECT_EQ(viewer.welcome().global_sequence, seq);
  ASSERT_TRUE(viewer.subscribe(viewer.all_coarse_tiles(0)).ok());
  EXPECT_TRUE(viewer.wait_until([&] { return viewer.tile_hash_messages() > 0; }, 20s));
  // No partial snapshot is left to hold the space.
  for (const auto& e : fs::directory_iterator(dir + "/snapshots"))
    EXPECT_NE(e.path().filename().string().rfind(".tmp-", 0), 0u) << e.path();
  // Space returns: edits are accepted again without a restart.
  make_room();
  bool accepted = false;
  const auto deadline = std::chrono::steady_clock::now() + 40s;
  while (!accepted && std::chrono::steady_clock::now() < deadline) {
    const uint32_t s = *c.deform(random_stamp(rng, c.welcome().world));
    ASSERT_TRUE(c.wait_until([&] { return c.ack(s).has_value(); }, 10s));
    accepted = c.ack(s)->accepted;
    if (accepted) seq = c.ack(s)->global_seq;
    if (!accepted) std::this_thread::sleep_for(200ms);  // the server retries on its own schedule
  }
  ASSERT_TRUE(accepted) << server.log();
  EXPECT_NE(server.log().find("event=storage_resumed"), std::string::npos) << server.log();
  EXPECT_EQ(server.terminate(), 0) << server.log();
  // Every acknowledged stamp is in the log, and nothing refused is.
  auto r = server::replay_log(server::list_segments(dir), dir);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  EXPECT_EQ(r->last_seq, seq);
}

}  // namespace
}  // namespace loam::test
