// SnapshotStore: incremental snapshots (format 3). A snapshot writes only the tiles that
// changed since the previous one into a new tiles file, plus a full index of every edited
// tile naming the file and offset that holds it; unchanged tiles stay where an earlier
// snapshot wrote them. The store is also where a World reads evicted edited tiles back
// (EditedTileSource), so a server's memory follows what is viewed and what changed since the
// last snapshot, not everything ever edited.
//
// Layout under <data>/snapshots/:
//   tiles/tiles-<n, 20 digits>.loamtiles  "LOAMTILE", format u32, reserved u32; records of
//     kind u8 (0 coarse, 1 detail, 2 stamp image), mip u8, tx i32, ty i32 (an image: width,
//     height), version u64, hash u64 (an image: its id), payload size u32, payload (region
//     codec, fast; an image: raw little-endian u16); then the record count u64 and an XXH3-64
//     of every byte before it. Files are immutable once their snapshot is in place.
//   snapshot-<seq>/index.bin  "LOAMSIDX", format u32, entry count u64, image count u32; per
//     edited tile kind, mip, tx, ty, version, hash, base hash u64 (the base's tile under a
//     coarse tile), file u64, offset u64 (the record's start), size u32 (0: a detail tile with
//     no samples); per image id u64, width i32, height i32, file, offset, size; an XXH3-64.
//   snapshot-<seq>/manifest.json  as format 2, plus the index's size, the tiles files it
//     references and what the write cost.
// Written as before: the tiles file is fsynced, the snapshot folder is written under a
// temporary name, fsynced and renamed into place, so a crash leaves the old set or the new one
// (a tiles file no snapshot names is removed by the next prune).
//
// Space: each write also moves the live records of sparse tiles files (at most half live) into
// its own file, within a budget of the changed tiles' bytes less the index and manifest, so a
// snapshot writes at most twice what changed (or the index alone, when that is larger) and the
// files hold about twice the live tiles plus what the retained snapshots still name. prune() keeps the newest
// `keep_snapshots` snapshots and removes the files only older ones named.
//
// Safe on untrusted input: loading checks the manifest, the index checksum, every entry's
// coordinates, size and file range, and (verify_tiles) decodes every record and compares its
// hash before the world is handed out; a damaged snapshot is an Error. Reads after that cannot
// fail: a tiles file damaged since stops the process with a message naming it (World reads
// never fail, and serving wrong terrain would diverge every client).
// Threading: one thread at a time (the server's tick thread).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "protocol/snapshot/snapshot.h"

namespace loam {

inline constexpr uint32_t kSnapshotFormatIncremental = 3;

// Where one edited tile (or stamp image) lies in the store.
struct StoredTile {
  uint8_t kind = 0;  // 0 coarse, 1 detail, 2 stamp image
  uint8_t mip = 0;
  int32_t tx = 0, ty = 0;  // an image: width, height
  uint64_t version = 0;
  uint64_t hash = 0;       // an image: its id
  uint64_t base_hash = 0;  // coarse: the base's tile under it
  uint64_t file = 0;
  uint64_t offset = 0;  // the record's first byte
  uint32_t size = 0;    // payload bytes
};

// What one snapshot write cost.
struct SnapshotWrite {
  std::string path;
  uint64_t last_seq = 0;
  size_t tiles_written = 0;     // tiles changed since the previous snapshot
  uint64_t tile_bytes = 0;      // their records (header and encoded payload)
  uint64_t tile_raw_bytes = 0;  // their samples, uncompressed
  size_t images_written = 0;
  size_t records_moved = 0;  // live records moved out of sparse files
  uint64_t moved_bytes = 0;
  uint64_t index_bytes = 0;
  uint64_t written_bytes = 0;  // everything: tiles file, index, manifest
  size_t index_entries = 0;
  double seconds = 0;  // the write on the worker (run), by its own clock: begin and finish read none
};

struct RetentionPolicy {
  uint32_t keep_snapshots = 3;  // the newest snapshots kept (at least 1)
};

struct PruneReport {
  size_t snapshots_removed = 0;
  size_t tile_files_removed = 0;
  uint64_t bytes_freed = 0;
  // The log segment the oldest kept snapshot continues with: segments before it are needed
  // only to replay from the initial terrain.
  uint32_t oldest_needed_segment = 0;
};

// The entries of an index.bin, checked as load() checks them before any tiles file is opened
// (checksum, counts against the size, kinds, coordinates in the world, payload sizes, no tile
// twice). Safe on untrusted input; for load(), tests and fuzzing.
struct SnapshotIndex {
  std::vector<StoredTile> tiles;
  std::vector<StoredTile> images;
};
Result<SnapshotIndex> parse_snapshot_index(std::span<const uint8_t> bytes, const WorldParams& world,
                                           const std::string& path);

struct SnapshotJob;
// One snapshot being written (SnapshotStore::begin, run, finish). Dropped unfinished, it
// removes the tiles file it may have written: no snapshot names it.
class SnapshotJobHandle {
 public:
  SnapshotJobHandle(SnapshotJobHandle&&) noexcept;
  SnapshotJobHandle& operator=(SnapshotJobHandle&&) noexcept;
  ~SnapshotJobHandle();
  // Written and in place (run succeeded).
  bool written() const { return done_; }

 private:
  friend class SnapshotStore;
  explicit SnapshotJobHandle(std::unique_ptr<SnapshotJob> job);
  std::unique_ptr<SnapshotJob> job_;
  bool done_ = false;
};

class SnapshotStore final : public EditedTileSource, public std::enable_shared_from_this<SnapshotStore> {
 public:
  // A store over <data_dir>/snapshots holding nothing yet: the next write writes every edited
  // tile. Reads the folder only (nothing is created or removed until a write or prune).
  static std::shared_ptr<SnapshotStore> open(const std::string& data_dir);
  ~SnapshotStore() override;

  // Loads an incremental snapshot of this store: the returned world reads its edited tiles
  // from the store, lazily; the store continues from its index. `base` as in read_snapshot.
  Result<LoadedSnapshot> load(const std::string& snapshot_path, std::shared_ptr<const TileBase> base,
                              bool verify_tiles = true);

  // Writes a snapshot of `world` after `last_seq`: its unpersisted tiles, the images not yet
  // stored, and the full index. Afterwards the world reads evicted tiles from this store and
  // the tiles written are clean. On failure nothing is left in place and the world is unchanged.
  Result<SnapshotWrite> write(World& world, uint64_t last_seq, uint32_t next_segment_index,
                              const TextureRegistry& textures, const SnapshotSession& session = {});
  // write() in three steps, so the expensive one runs off the owner's thread:
  //   begin (owner's thread): copies the tiles that changed and what the index needs;
  //   run (any thread, one job at a time): encodes, writes the tiles file, the index and the
  //     manifest, and publishes the snapshot; it reads only the job and immutable files;
  //   finish (owner's thread, after run succeeded): the store describes the new snapshot and
  //     the world's tiles still at their captured versions are clean.
  // The world may change between begin and finish (its tiles changed since stay dirty); no
  // other write or prune may run meanwhile.
  SnapshotJobHandle begin(const World& world, uint64_t last_seq, uint32_t next_segment_index,
                          const TextureRegistry& textures, const SnapshotSession& session = {});
  static Status run(SnapshotJobHandle& job);
  Result<SnapshotWrite> finish(World& world, SnapshotJobHandle job);

  // Removes snapshots beyond the newest `keep_snapshots`, the tiles files no remaining one
  // names, and partial folders and orphan files a crash left.
  Result<PruneReport> prune(const RetentionPolicy& policy);

  // EditedTileSource: the tile as the current index holds it.
  void read_coarse_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const override;
  void read_detail_tile(int32_t tx, int32_t ty, std::span<int8_t> out) const override;

  size_t index_entries() const { return index_.size(); }
  // Bytes of the tiles files the current index names, and of the records it uses in them.
  uint64_t file_bytes() const;
  uint64_t live_bytes() const;
  const std::string& data_dir() const { return data_dir_; }

 private:
  struct FileInfo {
    uint64_t bytes = 0;  // the whole file
    uint64_t live = 0;   // records the current index names
  };
  explicit SnapshotStore(std::string data_dir) : data_dir_(std::move(data_dir)) {}
  std::string tiles_path(uint64_t file) const;
  int fd_of(uint64_t file) const;
  // Reads one record's payload and checks its header against the entry.
  Result<std::vector<uint8_t>> read_payload(const StoredTile& e) const;
  [[noreturn]] void damaged(const StoredTile& e, const Error& error) const;
  void recount_live();

  std::string data_dir_;
  std::unordered_map<TileCoord, StoredTile, TileCoordHash> index_;  // kinds 0 and 1
  std::map<uint64_t, StoredTile> images_;                           // by id
  std::map<uint64_t, FileInfo> files_;
  uint64_t next_file_ = 1;
  mutable std::map<uint64_t, int> fds_;
};

// The tiles file name of file number `n`, and the folder holding them.
std::string snapshot_tiles_file_name(uint64_t n);
std::string snapshot_tiles_dir(const std::string& data_dir);

}  // namespace loam
