// The server's data folder: the deformation log (segments under log/) and snapshots (under
// snapshots/), and recovery from them.
//
// open_storage() starts a fresh session (initial terrain, segment 0) in an empty folder, or
// recovers: the torn tail of the last segment is truncated and reported, segments must chain,
// the newest valid snapshot not beyond the log is loaded (an invalid one is reported and
// skipped), and the records after it are replayed. Durability is explicit: append() buffers,
// sync() makes everything appended durable (the server acknowledges stamps only after it).
#pragma once

#include <optional>
#include <string>

#include "protocol/log/log_file.h"
#include "protocol/result.h"
#include "server/terrain_state.h"

namespace loam::server {

struct RecoveryReport {
  bool fresh = true;
  std::string snapshot_path;  // empty: started from the initial terrain
  uint64_t snapshot_seq = 0;
  size_t segments = 0;
  uint64_t replayed_records = 0;
  uint64_t truncated_bytes = 0;
  std::string damage;                // what recovery repaired, for the server's log
  std::vector<std::string> skipped;  // invalid snapshots, with why
  uint64_t last_seq = 0;
};

class Storage {
 public:
  Storage(Storage&&) noexcept = default;
  Storage& operator=(Storage&&) noexcept = default;

  Status append(const log::LogRecord& r) { return writer_->append(r); }
  Status sync() { return writer_->sync(); }
  // Writes a snapshot of the terrain after its last sequence and starts a new log segment
  // chained to it. Call after sync(). Returns the snapshot's path.
  Result<std::string> snapshot(const TerrainState& terrain);
  uint64_t last_snapshot_seq() const { return last_snapshot_seq_; }
  const std::string& data_dir() const { return data_dir_; }
  uint32_t segment_index() const { return writer_->header().segment_index; }

 private:
  friend struct StorageOpener;
  Storage() = default;
  std::string data_dir_;
  std::optional<log::LogWriter> writer_;
  log::InitialTerrain initial_;
  uint64_t last_snapshot_seq_ = 0;
};

struct OpenedStorage {
  Storage storage;
  TerrainState terrain;
  RecoveryReport report;
};

// `dem_path` (empty: the embedded default) is used only when the folder holds no session.
// `stamp_images` are texture-stamp image files registered before any replay (images stored
// in the loaded snapshot are registered too).
// `dem_band` names the DEM's height band (0: its only band).
Result<OpenedStorage> open_storage(const std::string& data_dir, const std::string& dem_path,
                                   const StampLimits& limits,
                                   const std::vector<std::string>& stamp_images = {}, int dem_band = 0);

// Segment files under <data_dir>/log, in index order.
std::vector<std::string> list_segments(const std::string& data_dir);

}  // namespace loam::server
