// World: the tiled terrain of one session — coarse mips, sparse detail, versions, hashes.
//
// Coarse heights are uint16 tiles at every mip (mip m holds every 2^m-th mip-0 sample;
// samples of a mip tile that fall outside the world repeat the nearest edge sample). The
// detail layer holds int8 offsets on a grid detail_factor times finer, mip 0 only, and is
// sparse: an all-zero detail tile is not stored. Writers change mip-0 samples and mark the
// rects they changed; commit(seq) then brings mips, hashes and versions up to date and
// reports, per tile, the rect that changed. Pure data: no I/O, no GL.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <unordered_map>
#include <vector>

#include "protocol/geometry.h"
#include "protocol/result.h"

namespace loam {

struct TileState {
  uint64_t version = 0;  // sequence number of the last stamp that changed the tile
  uint64_t hash = 0;     // hash of its samples (tile_hash.h)
};

// One tile changed by a commit: which samples, and its version before and after.
struct TileChange {
  TileCoord coord;
  RectI rect;  // changed samples in tile-local coordinates, inside [0, kTileSize)^2
  uint64_t base_version = 0;
  uint64_t new_version = 0;
};

class World {
 public:
  // A world with every coarse sample at `fill` and no detail. `params` must validate.
  explicit World(const WorldParams& params, uint16_t fill = 0);

  // A world from row-major coarse samples covering params.sample_rect() exactly.
  static Result<World> from_samples(const WorldParams& params, std::span<const uint16_t> samples);

  World(World&&) noexcept = default;
  World& operator=(World&&) noexcept = default;
  World(const World&) = default;
  World& operator=(const World&) = default;

  const WorldParams& params() const { return params_; }

  // --- Samples (global sample coordinates; reads outside the world clamp to its edge) ---
  uint16_t coarse(int64_t gx, int64_t gy) const;
  int8_t detail(int64_t dx, int64_t dy) const;  // detail grid; 0 where no tile is stored
  // Reads a rect (any position; clamped) into row-major `out` of r.area() samples.
  void read_coarse(const RectI& r, std::span<uint16_t> out) const;
  void read_detail(const RectI& r, std::span<int8_t> out) const;
  // Writes the part of a rect inside the world; only samples that differ are marked dirty.
  // Returns the number of samples that changed.
  int64_t write_coarse(const RectI& r, std::span<const uint16_t> in);
  int64_t write_detail(const RectI& r, std::span<const int8_t> in);

  // --- Tiles, for kernels that work tile by tile ---
  // Any coarse mip tile in the world's tile range (empty span outside it).
  std::span<const uint16_t> coarse_tile(int32_t mip, int32_t tx, int32_t ty) const;
  // A mip-0 coarse tile to modify in place; call mark_dirty for every sample changed.
  std::span<uint16_t> coarse_tile_mut(int32_t tx, int32_t ty);
  // A stored detail tile, or an empty span where the tile is all zero.
  std::span<const int8_t> detail_tile(int32_t tx, int32_t ty) const;
  // A detail tile to modify in place (created as zeros); call mark_dirty for changes.
  std::span<int8_t> detail_tile_mut(int32_t tx, int32_t ty);
  // Records that samples in `global_rect` (the layer's global sample grid) changed.
  void mark_dirty(Layer layer, const RectI& global_rect);

  // Applies everything marked since the last commit: mips, hashes, and versions = seq.
  // Returns every tile (all layers and mips) whose content changed, sorted by coordinate.
  std::vector<TileChange> commit(uint64_t seq);
  bool has_pending() const { return !pending_.empty(); }

  // --- Versions and hashes (committed state) ---
  TileState tile_state(const TileCoord& c) const;
  // Sets a tile's version without changing its content (loading a snapshot, which stores
  // versions beside the samples). Returns false for a tile outside the world.
  bool restore_version(const TileCoord& c, uint64_t version);
  // The world's identity: its parameters (spacing, vertical scale and offset, detail factor
  // and scale, origin, size) and its content_hash(), so a re-import at another scale hashes
  // differently (docs/world.md, "World hash").
  uint64_t world_hash() const;
  // Hash of every mip-0 coarse tile and every stored detail tile, in canonical order: the
  // content alone (what version 1 logs and older snapshots recorded as the world hash).
  uint64_t content_hash() const;
  size_t detail_tile_count() const { return detail_.size(); }
  std::vector<TileCoord> stored_detail_tiles() const;

 private:
  struct CoarseMip {
    RectI tiles;  // tile range at this mip
    std::vector<std::vector<uint16_t>> data;
    std::vector<TileState> state;
  };
  static int64_t key(int32_t tx, int32_t ty) {
    return int64_t((uint64_t(uint32_t(tx)) << 32) | uint32_t(ty));
  }
  size_t tile_index(int32_t mip, int32_t tx, int32_t ty) const;
  bool tile_in_range(int32_t mip, int32_t tx, int32_t ty) const;
  void update_mips(const RectI& dirty0, std::unordered_map<TileCoord, RectI, TileCoordHash>& changed);

  WorldParams params_;
  RectI samples_;         // params_.sample_rect()
  RectI detail_samples_;  // params_.detail_sample_rect()
  std::vector<CoarseMip> mips_;
  std::unordered_map<int64_t, std::vector<int8_t>> detail_;
  std::unordered_map<int64_t, TileState> detail_state_;  // tiles ever changed
  // Pending dirty rects per mip-0 tile (tile-local coordinates), merged per tile.
  std::unordered_map<TileCoord, RectI, TileCoordHash> pending_;
};

// World::world_hash of a world with these parameters and this content hash.
uint64_t world_hash_of(const WorldParams& params, uint64_t content_hash);

}  // namespace loam
