// The server's data folder: the deformation log (segments under log/), snapshots (under
// snapshots/) and the texture-stamp images (under images/), and recovery from them.
//
// open_storage() starts a fresh session (initial terrain, segment 0) in an empty folder, or
// recovers: the torn tail of the last segment is truncated and reported (a complete record
// that fails its checksum is media damage and stops recovery: `loam-server log repair`), the
// newest valid snapshot not beyond the log is loaded, and only the segments from the one that
// continues it are read and replayed (damage in older segments is reported, not fatal). Each
// segment's records replay under the stamp limits its header recorded; a record that fails to
// apply is an error naming it. If the options' limits differ from the recorded ones, a new
// segment recording them starts before any new stamp. Durability is explicit: append()
// buffers, sync() makes everything appended durable (the server acknowledges only after it).
//
// Snapshots are incremental (protocol/snapshot/snapshot_store.h): each writes the tiles changed
// since the previous one. The store is also where the world reads evicted edited tiles back, so
// the terrain's memory follows the server's cache budget and what changed since the last
// snapshot. After each snapshot the retention policy prunes older snapshots, the tiles files
// only they named, and log segments that the kept snapshots cover once the log exceeds its cap.
#pragma once

#include <atomic>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "protocol/log/log_file.h"
#include "protocol/result.h"
#include "protocol/snapshot/snapshot_store.h"
#include "server/terrain_source.h"
#include "server/terrain_state.h"

namespace loam::server {

struct RecoveryReport {
  bool fresh = true;
  std::string snapshot_path;  // empty: started from the initial terrain
  uint64_t snapshot_seq = 0;
  size_t segments = 0;          // segments read
  size_t segments_skipped = 0;  // older segments the snapshot made unnecessary
  uint64_t replayed_records = 0;
  uint64_t truncated_bytes = 0;
  std::string damage;                     // what recovery repaired, for the server's log
  std::vector<std::string> skipped;       // invalid snapshots, with why
  std::vector<std::string> older_damage;  // damage in segments before the snapshot (not needed)
  std::vector<std::string> images_damaged;
  size_t images_loaded = 0;
  size_t partial_snapshots_removed = 0;
  // The limits the log recorded (when they differ from the options, a new segment now records
  // the options' limits), and whether a new segment was started for that.
  std::optional<StampLimits> recorded_limits;
  bool limits_changed = false;
  uint64_t last_seq = 0;
  uint64_t last_tick = 0;
};

// What the data folder keeps (docs/configuration.md, "Retention").
struct StorageRetention {
  uint32_t keep_snapshots = 3;  // the newest snapshots (at least 1)
  // Log segments older than the oldest kept snapshot are removed, oldest first, while the log
  // exceeds this many bytes; until then a replay from the initial terrain stays possible.
  // UINT64_MAX: keep the whole log.
  uint64_t log_cap_bytes = uint64_t(1) << 30;
};

struct SnapshotOutcome {
  SnapshotWrite write;
  PruneReport prune;
  size_t segments_removed = 0;
  uint64_t segment_bytes_removed = 0;
};

class Storage {
 public:
  Storage(Storage&&) noexcept = default;
  Storage& operator=(Storage&&) noexcept = default;
  ~Storage();  // waits for a snapshot being written

  Status append(const log::LogRecord& r) {
    if (!writer_->is_open())
      return make_error(ErrorCode::kIo, writer_->path(), "log is closed after a failure");
    return writer_->append(r);
  }
  Status sync() { return writer_->sync(); }
  // False after a failed sync() until resume() succeeds.
  bool writable() const { return writer_->is_open(); }
  // After a failed sync: checks that the file system has room again, cuts the segment back to
  // what was durable and reopens it. `last_seq` is the last sequence the server applied.
  Status resume(uint64_t last_seq);
  // Writes a snapshot of the terrain after its last sequence and starts a new log segment
  // chained to it. Call after sync(). Returns the snapshot's path. On failure nothing is left
  // behind and the log goes on in the current segment.
  // `reuse_existing`: a valid snapshot at the terrain's sequence is already there (only the
  // segment is new: the limits changed).
  // The tiles written become clean in the world (evictable under its cache budget).
  Result<SnapshotOutcome> snapshot(TerrainState& terrain, uint64_t tick, bool reuse_existing = false);
  // The same with the writing on a worker thread: begin_snapshot() copies what changed and
  // starts the new segment at once (so the tick goes on logging); poll_snapshot() adopts the
  // snapshot once written (nullopt while it is being written; `wait`: block until it is) and
  // applies retention. A failed write leaves the previous snapshots and the whole log in place.
  // One at a time.
  // `created_unix_us`: the wall time the next segment records as its creation (the caller's
  // clock: the replication core reads none).
  Status begin_snapshot(TerrainState& terrain, uint64_t tick, uint64_t created_unix_us);
  bool snapshot_in_flight() const { return pending_ != nullptr; }
  std::optional<Result<SnapshotOutcome>> poll_snapshot(TerrainState& terrain, bool wait);
  uint64_t last_snapshot_seq() const { return last_snapshot_seq_; }
  void set_retention(const StorageRetention& r) { retention_ = r; }
  const SnapshotStore& store() const { return *store_; }
  // Bytes of the data folder's log segments and snapshots (walks the folder).
  uint64_t log_bytes() const;
  uint64_t snapshot_bytes() const;
  const std::string& data_dir() const { return data_dir_; }
  uint32_t segment_index() const { return writer_->header().segment_index; }
  // The tick of the last record (or segment start): the server's ticks continue from it.
  uint64_t last_tick() const { return writer_->last_tick(); }
  // The limits the current segment records: the ones live stamps are checked and applied under.
  const StampLimits& limits() const { return writer_->header().limits; }
  // Free bytes below which edits are refused (a full disk): the log needs room for a tick.
  static constexpr uint64_t kMinFreeBytes = 1u << 20;

 private:
  friend struct StorageOpener;
  Storage() = default;
  std::string segment_path_of(uint32_t index) const;
  // Syncs the log and starts segment `next` continuing from the terrain's last sequence.
  Status roll_segment(const TerrainState& terrain, uint64_t tick, uint64_t created_unix_us);
  void apply_retention(SnapshotOutcome& out);
  struct PendingSnapshot {
    explicit PendingSnapshot(SnapshotJobHandle j) : job(std::move(j)) {}
    SnapshotJobHandle job;
    Status status;
    std::atomic<bool> done{false};
    std::thread worker;
  };
  std::string data_dir_;
  std::optional<log::LogWriter> writer_;
  log::InitialTerrain initial_;
  uint64_t last_snapshot_seq_ = 0;
  std::shared_ptr<SnapshotStore> store_;
  StorageRetention retention_;
  std::unique_ptr<PendingSnapshot> pending_;
};

struct OpenedStorage {
  Storage storage;
  TerrainState terrain;
  RecoveryReport report;
};

// `dem_path` (empty: the embedded default) is used only when the folder holds no session.
// `limits` are the options' stamp limits: a fresh session records them; a recovered one replays
// under the recorded ones and records these for what follows. `stamp_images` are texture-stamp
// image files to register; they are stored in the folder, and every image stored there (and in
// the loaded snapshot) is registered before any replay. `dem` names the DEM's height band and
// NoData fill (terrain_source.h). `terrain` names the embedded terrain used without a DEM (terrain_source.h).
Result<OpenedStorage> open_storage(const std::string& data_dir, const std::string& dem_path,
                                   const StampLimits& limits,
                                   const std::vector<std::string>& stamp_images = {},
                                   const DemChoice& dem = {}, const std::string& terrain = kTerrainCrop);

// Bytes of the regular files under `dir`, recursively (0 where it is absent).
uint64_t folder_bytes(const std::string& dir);

// The session's current world without changing the folder (export, inspection): like a
// recovery, but a damaged tail is left alone (its records before the damage count), nothing is
// written, and the returned Storage must not be used to log.
Result<OpenedStorage> read_session(const std::string& data_dir);

// Segment files under <data_dir>/log, in index order.
std::vector<std::string> list_segments(const std::string& data_dir);

// Free bytes for an unprivileged writer on the file system holding `path` (statvfs).
Result<uint64_t> free_bytes(const std::string& path);

}  // namespace loam::server
