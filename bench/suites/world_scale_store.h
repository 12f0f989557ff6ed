// The world-scale suite's storage parts (world_scale_suite.cpp runs them): importing a DEM of
// tens of thousands of samples a side into a tile pack in bounded memory, and incremental
// snapshots with retention over a long session.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "bench/harness.h"

namespace loam::bench {

struct PackImportBench {
  bool ran = false;
  std::string note;  // why it did not run, or what failed
  int64_t side = 0;
  std::string layout;  // "tiled 256x256" or "striped"
  double generate_s = 0;
  double import_s = 0, peak_rss_mib = 0;
  double source_mib = 0;  // 16-bit samples
  uint64_t pack_bytes = 0, pack_tiles = 0;
  std::string pack_path;  // left in place for the serving run
};

// Generates a side x side GeoTIFF from the shared ETOPO5 (gdal_translate: a 1024^2 window over
// Asia, resampled bilinearly) under `dir`, then times `loam-server import --pack` on it as a
// child process (peak RSS from wait4).
PackImportBench bench_pack_import(const Context& ctx, const std::string& dir, int64_t side, bool tiled);

struct SnapshotRound {
  uint64_t stamps = 0;
  size_t tiles_written = 0;
  uint64_t tile_bytes = 0, written_bytes = 0, moved_bytes = 0, index_bytes = 0;
  double write_s = 0;
  uint64_t data_dir_bytes = 0, log_bytes = 0, snapshot_bytes = 0;
  uint64_t live_bytes = 0;  // records the newest snapshot's index uses
};

struct SnapshotBench {
  bool ran = false;
  std::string note;
  uint64_t stamps = 0, every = 0;
  uint32_t keep_snapshots = 0;
  uint64_t log_cap_bytes = 0;
  std::vector<SnapshotRound> rounds;
  double worst_ratio = 0;  // written / changed tile bytes, over every round
  double restart_s = 0;    // recovery of the final data folder
  uint64_t restart_replayed = 0;
  uint64_t edited_tiles = 0;
  double stamps_per_s = 0;
};

// A session on the refined world driven in-process (no network): `stamps` stamps by 16
// roaming "players" (near themselves, as the bots), logged and synced per tick of 64, a
// snapshot every `every` stamps with the server's retention; then a restart (recovery) timed.
SnapshotBench bench_snapshots(const Context& ctx, uint64_t stamps, uint64_t every, uint32_t keep_snapshots,
                              uint64_t log_cap_bytes);

}  // namespace loam::bench
