// Snapshots and storage, part of ReplicationCore: a snapshot begun when SnapshotSchedule
// (snapshot_schedule.h) says it is due and adopted once written, its outcome logged, the log
// reopened after a failed sync when StorageRetry allows, and the base cache trimmed after the
// tick.
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
  if (!storage_retry_.may_try(now)) return;
  if (const Status st = storage_.resume(commits_.sequenced_seq()); !st.ok()) {
    const double next_in_s = storage_retry_.reopen_failed(now);
    note("storage_retry", {{"error", st.error().describe()}, {"next_in_s", std::to_string(next_in_s)}});
    return;
  }
  note("storage_resumed", {{"seq", std::to_string(commits_.sequenced_seq())}});
}

void ReplicationCore::maybe_snapshot(CoreTime now, UnixMicros wall, bool force) {
  // A snapshot reads and adopts into the world, at the applied sequence: only while no apply
  // runs and nothing sequenced waits for one (the log's next segment starts after it).
  if (!commits_.settled()) return;
  // A snapshot being written on its worker: adopted once written (at shutdown, waited for).
  if (storage_.snapshot_in_flight()) {
    auto done = storage_.poll_snapshot(terrain_, force);
    if (!done) return;
    snapshot_done(*done, now);
    if (!force) return;
  }
  if (!storage_.writable()) return;  // the log must be writable to start the next segment
  const SnapshotSchedule::WorldState state{terrain_.last_seq(), storage_.last_snapshot_seq(),
                                           terrain_.world().unpersisted_bytes()};
  if (!snapshots_.due(now, state, force)) return;
  snapshots_.began(now);
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
    // Nothing is left behind (a failed write removes what it wrote).
    const double retry_in_s = snapshots_.failed(now);
    note("snapshot_error", {{"error", done.error().describe()}, {"retry_in_s", std::to_string(retry_in_s)}});
    return;
  }
  // From the tick that began it to the one that adopted it (0: written within one call).
  const double ms = snapshots_.written(now);
  const SnapshotWrite& w = done->write;
  stats_.snapshot_bytes_written += w.written_bytes;
  ++stats_.snapshots;
  note("snapshot", {{"path", w.path},
                    {"seq", std::to_string(w.last_seq)},
                    {"tiles", std::to_string(w.tiles_written)},
                    {"tile_bytes", std::to_string(w.tile_bytes)},
                    {"moved_bytes", std::to_string(w.moved_bytes)},
                    {"index_bytes", std::to_string(w.index_bytes)},
                    {"written_bytes", std::to_string(w.written_bytes)},
                    {"snapshots_removed", std::to_string(done->prune.snapshots_removed)},
                    {"tile_files_removed", std::to_string(done->prune.tile_files_removed)},
                    {"segments_removed", std::to_string(done->segments_removed)},
                    {"ms", std::to_string(ms)}});
}

}  // namespace loam::server
