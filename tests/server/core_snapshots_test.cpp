// Snapshots and storage (server/replication/core_snapshots.cpp): a snapshot when due by stamps
// or by the interval on the time the core is given, and the wall time the transport gives
// recorded by the log segment that continues it.
#include "protocol/log/log_file.h"
#include "server/storage.h"
#include "tests/server/core_harness.h"

namespace loam::server {
namespace {

using namespace std::chrono_literals;
using core_test::CoreHarness;

TEST(CoreSnapshots, ASnapshotDueByStampsStartsASegmentThatRecordsTheGivenWallTime) {
  ServerConfig config;
  config.snapshot_every_stamps = 2;
  config.async_snapshots = false;
  CoreHarness h(config);
  const auto [a, b] = h.two_players_in_sync();
  h.send(a, wire::Deform{1, h.stamp(StampKind::kCrater, 100.0, 100.0, 8.0)});
  h.tick();
  EXPECT_EQ(h.core().metrics().snapshots, 0u) << "one stamp: not due";
  h.send(a, wire::Deform{2, h.stamp(StampKind::kGaussian, 300.0, 100.0, 8.0)});
  h.tick();
  const MetricsSnapshot m = h.core().metrics();
  EXPECT_EQ(m.snapshots, 1u);
  EXPECT_EQ(m.snapshot_sequence, 2u);
  const auto segments = list_segments(h.dir().string());
  ASSERT_EQ(segments.size(), 2u);
  auto next = log::read_segment(segments[1]);
  ASSERT_TRUE(next.ok()) << next.error().describe();
  EXPECT_EQ(next->header.header.base_seq, 2u);
  // Not the clock's: the time the harness gave the tick.
  EXPECT_EQ(next->header.header.created_unix_us, CoreHarness::kWall);
}

TEST(CoreSnapshots, ASnapshotDueByTheIntervalFollowsTheTimeGivenNotTheClock) {
  ServerConfig config;
  config.snapshot_interval_s = 60;
  config.async_snapshots = false;
  CoreHarness h(config);
  const auto [a, b] = h.two_players_in_sync();
  h.send(a, wire::Deform{1, h.stamp(StampKind::kCrater, 100.0, 100.0, 8.0)});
  h.tick(30s);
  EXPECT_EQ(h.core().metrics().snapshots, 0u);
  // A minute of made-up time passes in one call: the interval is the core's time, not the wall's.
  h.tick(31s);
  EXPECT_EQ(h.core().metrics().snapshots, 1u);
  // Nothing new since: no second one, however long it waits.
  h.tick(600s);
  EXPECT_EQ(h.core().metrics().snapshots, 1u);
}

}  // namespace
}  // namespace loam::server
