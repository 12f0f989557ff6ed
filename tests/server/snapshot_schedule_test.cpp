// SnapshotSchedule and StorageRetry (server/replication/snapshot_schedule.h) on a made-up
// clock: when a snapshot is due, the back-off after a failed one, and the log's reopen
// intervals after a failed sync.
#include "server/replication/snapshot_schedule.h"

#include <gtest/gtest.h>

namespace loam::server {
namespace {

using namespace std::chrono_literals;

const CoreTime kScheduleStart = CoreTime{} + 100s;

ServerConfig policy(uint64_t every, double interval_s, uint64_t dirty) {
  ServerConfig c;
  c.snapshot_every_stamps = every;
  c.snapshot_interval_s = interval_s;
  c.snapshot_dirty_bytes = dirty;
  return c;
}

TEST(SnapshotSchedule, DueByStampsByAgeOrByUnpersistedBytesButNeverWithNothingNew) {
  SnapshotSchedule s(policy(100, 60, 1000), kScheduleStart);
  EXPECT_FALSE(s.due(kScheduleStart, {50, 0, 10}, false));
  EXPECT_TRUE(s.due(kScheduleStart, {100, 0, 10}, false)) << "100 stamps since";
  EXPECT_TRUE(s.due(kScheduleStart, {50, 0, 1000}, false)) << "the dirty budget is full";
  EXPECT_TRUE(s.due(kScheduleStart + 60s, {1, 0, 0}, false)) << "a minute old";
  // Nothing since the last one, or the initial terrain alone: nothing to write, even forced.
  EXPECT_FALSE(s.due(kScheduleStart + 600s, {40, 40, 5000}, false));
  EXPECT_FALSE(s.due(kScheduleStart, {0, 0, 5000}, true));
  EXPECT_TRUE(s.due(kScheduleStart, {1, 0, 0}, true)) << "shutdown writes what is new";
  // Age counts from the last one begun.
  s.began(kScheduleStart + 30s);
  EXPECT_FALSE(s.due(kScheduleStart + 60s, {1, 0, 0}, false));
  EXPECT_TRUE(s.due(kScheduleStart + 90s, {1, 0, 0}, false));
}

TEST(SnapshotSchedule, ZeroTurnsEachRuleOff) {
  SnapshotSchedule s(policy(0, 0, 0), kScheduleStart);
  EXPECT_FALSE(s.due(kScheduleStart + 10000s, {1u << 30, 0, 1u << 30}, false));
  EXPECT_TRUE(s.due(kScheduleStart, {1, 0, 0}, true));
}

TEST(SnapshotSchedule, AFailedOneBacksOffDoublingUpToFiveMinutesAndASuccessResetsIt) {
  SnapshotSchedule s(policy(1, 0, 0), kScheduleStart);
  const SnapshotSchedule::WorldState w{10, 0, 0};
  s.began(kScheduleStart);
  EXPECT_EQ(s.failed(kScheduleStart), 5.0);
  EXPECT_FALSE(s.due(kScheduleStart + 4s, w, false));
  EXPECT_TRUE(s.due(kScheduleStart + 4s, w, true)) << "shutdown does not wait for the back-off";
  EXPECT_TRUE(s.due(kScheduleStart + 5s, w, false));
  double last = 5.0;
  for (int i = 0; i < 10; ++i) last = s.failed(kScheduleStart);
  EXPECT_EQ(last, 300.0);
  s.began(kScheduleStart + 400s);
  EXPECT_EQ(s.written(kScheduleStart + 400s + 250ms), 250.0) << "milliseconds since it began";
  EXPECT_EQ(s.failed(kScheduleStart + 500s), 5.0) << "a success resets the back-off";
}

TEST(StorageRetry, AFailedSyncRetriesSoonAndEachFailedReopenWaitsTwiceAsLongUpToTenSeconds) {
  StorageRetry r;
  EXPECT_TRUE(r.may_try(kScheduleStart));
  r.sync_failed(kScheduleStart);
  EXPECT_FALSE(r.may_try(kScheduleStart + 200ms));
  EXPECT_TRUE(r.may_try(kScheduleStart + 250ms));
  EXPECT_EQ(r.reopen_failed(kScheduleStart + 250ms), 0.5);
  EXPECT_FALSE(r.may_try(kScheduleStart + 700ms));
  EXPECT_TRUE(r.may_try(kScheduleStart + 750ms));
  double s = 0;
  for (int i = 0; i < 10; ++i) s = r.reopen_failed(kScheduleStart);
  EXPECT_EQ(s, 10.0);
  r.sync_failed(kScheduleStart + 20s);  // a later failure starts over
  EXPECT_TRUE(r.may_try(kScheduleStart + 20s + 250ms));
}

}  // namespace
}  // namespace loam::server
