// When to write a snapshot and when to retry the storage: the policy alone, on the time it is
// given. A snapshot is due by stamps since the last one, by age, or by edited bytes no
// snapshot holds yet (those cannot be evicted, so past the dirty budget a snapshot makes them
// clean); a failed one is retried after an interval that doubles up to 5 minutes (a full disk
// would otherwise churn). A failed log sync refuses edits and the log is reopened after an
// interval that doubles from 0.25 s up to 10 s.
#pragma once

#include <cstdint>

#include "server/replication/core_time.h"
#include "server/server_config.h"

namespace loam::server {

class SnapshotSchedule {
 public:
  static constexpr double kBackoffMinS = 5.0, kBackoffMaxS = 300.0;

  SnapshotSchedule(const ServerConfig& config, CoreTime now);

  // What the world holds now: its last sequence, the last a snapshot holds, and the bytes of
  // edited tiles no snapshot holds.
  struct WorldState {
    uint64_t last_seq = 0, snapshot_seq = 0, unpersisted_bytes = 0;
  };
  // Whether to begin one now. `force` (shutdown) skips the back-off and the thresholds, not
  // the rule that a snapshot must add something: nothing since the last one (or since the
  // initial terrain, which the first log segment's header describes) is never due.
  bool due(CoreTime now, const WorldState& w, bool force) const;
  void began(CoreTime now);
  // A failed one: the seconds until the next try.
  double failed(CoreTime now);
  // A written one: milliseconds since it began.
  double written(CoreTime now);

 private:
  uint64_t every_stamps_;
  double interval_s_;
  uint64_t dirty_bytes_;
  CoreTime last_{}, started_{}, retry_after_{};
  double backoff_s_ = 0;
};

class StorageRetry {
 public:
  static constexpr double kMinS = 0.25, kMaxS = 10.0;

  bool may_try(CoreTime now) const { return now >= next_; }
  // The log's sync failed: the first reopen is tried after the shortest interval.
  void sync_failed(CoreTime now);
  // A reopen failed: the seconds until the next try.
  double reopen_failed(CoreTime now);

 private:
  double backoff_s_ = kMinS;
  CoreTime next_{};
};

}  // namespace loam::server
