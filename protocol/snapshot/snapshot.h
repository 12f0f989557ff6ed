// Snapshots: the whole terrain at one sequence number, so recovery is the newest valid
// snapshot plus the log segments after it. The server writes them; its recovery, the file
// tools and the client's headless renderer read them (a file format both sides agree on, like
// the log, hence protocol/).
//
// Snapshots are written incrementally (format 3, snapshot_store.h): each writes the tiles
// changed since the previous one and an index of every edited tile. Format 2, read only:
// <data>/snapshots/snapshot-<seq, 20 digits>/{manifest.json, tiles.bin}, where tiles.bin holds
// every edited mip-0 coarse tile and stored detail tile (region codec, fast mode) with its
// version and hash, then the versions of every mip tile, then the texture-stamp images, then
// an XXH3-64 of the file. Both are written into a temporary folder, every file fsynced, then
// renamed into place and the parent fsynced, so a crash leaves either the old set or the
// complete new one. Reading verifies the checksums, every tile hash and the world hash: a
// damaged snapshot is an Error (recovery then falls back to an older one), never a
// half-loaded world.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "protocol/result.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/stamps/texture_registry.h"
#include "protocol/world.h"

namespace loam {

struct SnapshotManifest {
  uint32_t format = 3;
  uint64_t snapshot_id = 0;  // = last_seq: the world after this sequence
  uint64_t last_seq = 0;
  uint64_t world_hash = 0;
  uint64_t created_unix_us = 0;
  uint32_t next_segment_index = 0;  // the log segment that continues from this snapshot
  WorldParams world;
  size_t coarse_tiles = 0, detail_tiles = 0;
  uint64_t tiles_bytes = 0;
  // The session settings that give the logged stamps their meaning, recorded beside the
  // terrain (absent in snapshots written before they were recorded).
  bool has_session = false;
  StampLimits limits;
  uint64_t tick = 0;
  // world_hash is World::world_hash (parameters included); false in older snapshots, whose
  // world_hash is World::content_hash.
  bool hash_covers_params = false;
  // The base the tiles are edits of (TileBase::identity and describe); snapshots written
  // before bases list every tile over a fill of 0.
  uint64_t base_identity = 0;
  std::string base_description;
  // Every tile's version 0 is the base's tile (World::initial_is_base); false in snapshots
  // written before it was recorded.
  bool initial_is_base = false;
  // Format 3: the index's size and the tiles files it names (snapshot_store.h).
  uint64_t index_bytes = 0;
  std::vector<uint64_t> tile_files;
};

// What a snapshot records of the session besides the terrain.
struct SnapshotSession {
  StampLimits limits;
  uint64_t tick = 0;
};

struct LoadedSnapshot {
  SnapshotManifest manifest;
  World world;
  std::string path;
  std::vector<StampTexture> textures;  // texture-stamp images, verified against their ids
};

std::string snapshot_dir_name(uint64_t snapshot_id);

// Writes a snapshot of `world` after `last_seq` under <data_dir>/snapshots/ through a store
// that holds nothing yet (every edited tile is written; a server keeps one SnapshotStore and
// writes through it instead). Returns its path. On failure (a full disk) nothing is left behind.
// Afterwards the world reads its evicted tiles from that store.
Result<std::string> write_snapshot(const std::string& data_dir, World& world, uint64_t last_seq,
                                   uint32_t next_segment_index, const TextureRegistry& textures,
                                   const SnapshotSession& session = {});
// Removes temporary folders that a crash during write_snapshot left under <data_dir>/snapshots.
// Returns how many it removed.
size_t remove_partial_snapshots(const std::string& data_dir);

// Reads and fully verifies one snapshot folder.
// `base` is the base the session runs on; the snapshot's tiles are edits of it, and its
// identity must be the one the manifest records. Without one, the snapshot's base must be a
// fill of 0 (every snapshot written before bases).
// `verify_tiles` (format 3): decode every tile and check its hash before returning (format 2
// always does); without it, entries are range-checked and tiles checked when first read.
Result<LoadedSnapshot> read_snapshot(const std::string& path, std::shared_ptr<const TileBase> base = nullptr,
                                     bool verify_tiles = true);
// Reads only the manifest (for `snapshot info` and listing).
Result<SnapshotManifest> read_snapshot_manifest(const std::string& path);

// Snapshot folders under <data_dir>/snapshots/, newest (highest id) first.
std::vector<std::string> list_snapshots(const std::string& data_dir);

// fsync a file or directory by path (used by snapshots and the data folder).
Status fsync_path(const std::string& path);

}  // namespace loam
