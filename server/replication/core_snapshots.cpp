// Snapshots and storage, part of ReplicationCore: a snapshot when due (by stamps, interval or
// unpersisted bytes) and its adoption once written, a growing back-off after a failed one, the
// log reopened after a failed sync, and the base cache trimmed after the tick.
#include <algorithm>

#include "server/replication/core_detail.h"
#include "server/replication/replication_core.h"

namespace loam::server {

using namespace core_detail;

void ReplicationCore::persist(CoreTime now, UnixMicros wall) {
  if (stopping_ || failed_) return;
  maybe_snapshot(now, wall, false);
}

void ReplicationCore::trim() {
  if (stopping_ || failed_) return;
  // Clean base tiles read this tick (subscriptions, stamps' neighbourhoods) back under budget;
  // nothing holds a span into them between ticks.
  terrain_.mutable_world().trim_base_cache();
  refresh_world_counters();
  tick_base_tiles_read_ = world_counters_.base_tiles_generated - tick_start_counters_.base_tiles_generated;
  tick_edited_tiles_loaded_ = world_counters_.edited_tiles_loaded - tick_start_counters_.edited_tiles_loaded;
}

void ReplicationCore::try_resume_storage(CoreTime now) {
  if (now < next_resume_try_) return;
  if (const Status st = storage_.resume(sequenced_seq_); !st.ok()) {
    resume_backoff_s_ = std::min(resume_backoff_s_ * 2.0, kResumeBackoffMaxS);
    next_resume_try_ = now + after(resume_backoff_s_);
    note("storage_retry",
         {{"error", st.error().describe()}, {"next_in_s", std::to_string(resume_backoff_s_)}});
    return;
  }
  note("storage_resumed", {{"seq", std::to_string(sequenced_seq_)}});
}

void ReplicationCore::maybe_snapshot(CoreTime now, UnixMicros wall, bool force) {
  // A snapshot reads and adopts into the world, at the applied sequence: only while no apply
  // runs and nothing sequenced waits for one (the log's next segment starts after it).
  if (applier_->busy() || !to_apply_.empty()) return;
  // A snapshot being written on its worker: adopted once written (at shutdown, waited for).
  if (storage_.snapshot_in_flight()) {
    auto done = storage_.poll_snapshot(terrain_, force);
    if (!done) return;
    snapshot_done(*done, now);
    if (!force) return;
  }
  if (!storage_.writable()) return;  // the log must be writable to start the next segment
  if (!force && now < snapshot_retry_after_) return;
  const uint64_t since = terrain_.last_seq() - storage_.last_snapshot_seq();
  const double age = seconds(now - last_snapshot_time_);
  // Edited tiles no snapshot holds cannot be evicted: past the dirty budget, a snapshot makes
  // them clean so the world stays within its cache budget.
  const bool dirty_full = config_.snapshot_dirty_bytes > 0 &&
                          terrain_.world().unpersisted_bytes() >= config_.snapshot_dirty_bytes;
  const bool due = force || dirty_full ||
                   (config_.snapshot_every_stamps > 0 && since >= config_.snapshot_every_stamps) ||
                   (config_.snapshot_interval_s > 0 && age >= config_.snapshot_interval_s && since > 0);
  // Nothing new since the last snapshot (or since the initial terrain, which segment 0's
  // header already describes): a snapshot would add nothing.
  if (!due || since == 0 || terrain_.last_seq() == 0) return;
  snapshot_started_ = now;  // for the log line only
  last_snapshot_time_ = now;
  // The tick thread copies what changed and starts the next segment; the encoding and writing
  // run on the storage's worker, so acks and events do not wait for them.
  const Status begun = storage_.begin_snapshot(terrain_, tick_, wall);
  if (!begun.ok()) {
    snapshot_done(Result<SnapshotOutcome>(begun.error()), now);
    return;
  }
  if (force || !config_.async_snapshots) snapshot_done(*storage_.poll_snapshot(terrain_, true), now);
}

void ReplicationCore::snapshot_done(const Result<SnapshotOutcome>& done, CoreTime now) {
  if (!done) {
    // Nothing is left behind (a failed write removes what it wrote); retrying at once on a
    // full disk would only churn, so the interval grows.
    snapshot_backoff_s_ = snapshot_backoff_s_ == 0
                              ? kSnapshotBackoffMinS
                              : std::min(snapshot_backoff_s_ * 2.0, kSnapshotBackoffMaxS);
    snapshot_retry_after_ = now + after(snapshot_backoff_s_);
    note("snapshot_error",
         {{"error", done.error().describe()}, {"retry_in_s", std::to_string(snapshot_backoff_s_)}});
    return;
  }
  snapshot_backoff_s_ = 0;
  const SnapshotWrite& w = done->write;
  stats_.snapshot_bytes_written += w.written_bytes;
  ++stats_.snapshots;
  note("snapshot",
       {{"path", w.path},
        {"seq", std::to_string(w.last_seq)},
        {"tiles", std::to_string(w.tiles_written)},
        {"tile_bytes", std::to_string(w.tile_bytes)},
        {"moved_bytes", std::to_string(w.moved_bytes)},
        {"index_bytes", std::to_string(w.index_bytes)},
        {"written_bytes", std::to_string(w.written_bytes)},
        {"snapshots_removed", std::to_string(done->prune.snapshots_removed)},
        {"tile_files_removed", std::to_string(done->prune.tile_files_removed)},
        {"segments_removed", std::to_string(done->segments_removed)},
        // From the tick that began it to the one that adopted it (0: written within one call).
        {"ms", std::to_string(std::chrono::duration<double, std::milli>(now - snapshot_started_).count())}});
}

}  // namespace loam::server
