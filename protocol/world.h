// World: the tiled terrain of one session — coarse mips, sparse detail, versions, hashes.
//
// Coarse heights are uint16 tiles at every mip (mip m holds every 2^m-th mip-0 sample;
// samples of a mip tile that fall outside the world repeat the nearest edge sample). The
// detail layer holds int8 offsets on a grid detail_factor times finer, mip 0 only, and is
// sparse: an all-zero detail tile is not stored. Writers change mip-0 samples and mark the
// rects they changed; commit(seq) then brings mips, hashes and versions up to date and
// reports, per tile, the rect that changed. Pure data: no I/O, no GL.
//
// A world is a read-only base (protocol/base/tile_base.h) plus edits. Coarse tiles ever
// written (at any mip) are held as edited tiles; every other tile is asked of the base when
// read and kept in a cache of clean tiles, which trim_base_cache() brings back under its
// budget, least recently used first. Edited tiles that a session's store has persisted at
// their current version (mark_persisted, with an EditedTileSource to read them back) are
// clean too: the same trim evicts them and a read loads them again, so memory follows what is
// viewed and what changed since the last snapshot, not everything ever edited. Spans returned
// by the readers stay valid until the next trim_base_cache() (or the world's destruction);
// writes never invalidate them. The world hash covers the base's identity and the edited
// tiles' states, so it needs no pass over the world and no tile read.
// Not thread-safe, even for const calls (the cache and a one-tile lookup memo change).
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <type_traits>
#include <unordered_map>
#include <vector>

#include "protocol/base/tile_base.h"
#include "protocol/geometry.h"
#include "protocol/layer.h"
#include "protocol/result.h"
#include "protocol/sparse_tiles.h"

namespace loam {

class WorldHasher;

// Where a world reads edited tiles back after evicting them: a session's snapshot store
// (protocol/snapshot/snapshot_store.h). It answers every tile the world adopted or marked
// persisted, at the version it was persisted with; like a TileBase it cannot fail (a store
// damaged after it was verified stops the process rather than serve wrong terrain).
class EditedTileSource {
 public:
  virtual ~EditedTileSource() = default;
  virtual void read_coarse_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const = 0;
  virtual void read_detail_tile(int32_t tx, int32_t ty, std::span<int8_t> out) const = 0;
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
  // A world whose untouched tiles come from `base` (made for these params).
  World(const WorldParams& params, std::shared_ptr<const TileBase> base);

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
  // The tile's samples in its row's type (the detail layer has mip 0 only).
  template <class R>
  std::span<const typename R::Sample> tile_samples(const TileCoord& c) const;
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
  // The version alone: never reads a tile (tile_state may generate an untouched one to hash it).
  uint64_t tile_version(const TileCoord& c) const;
  // tile_state() when it is known without asking the base (the tile is edited, cached, or its
  // hash remembered); nullopt when it would have to be generated or read first.
  std::optional<TileState> known_tile_state(const TileCoord& c) const;
  // Sets a tile's version without changing its content (loading a snapshot, which stores
  // versions beside the samples). Returns false for a tile outside the world.
  bool restore_version(const TileCoord& c, uint64_t version);
  // The world's identity: its parameters (spacing, vertical scale and offset, detail factor
  // and scale, origin, size) and its content_hash(), so a re-import at another scale hashes
  // differently (docs/world.md, "World hash").
  uint64_t world_hash() const;
  // Hash of every mip-0 coarse tile and every stored detail tile, in canonical order: the
  // content alone (what version 1 logs and older snapshots recorded as the world hash).
  //
  // The content hash is the base's identity, then every mip-0 coarse tile whose committed
  // content differs from the base's, then every stored detail tile, in canonical order
  // (docs/world.md, "World hash"): O(edited tiles), never a pass over the world.
  uint64_t content_hash() const;
  // The hash older logs and snapshots recorded: every mip-0 coarse tile in canonical order,
  // then the stored detail tiles. A pass over the whole world: only for checking old files.
  uint64_t legacy_content_hash() const;
  uint64_t legacy_world_hash() const;
  // Whether a hash a log or snapshot recorded for this world matches under any definition
  // Loam has written: world or content hash, current or legacy (the legacy ones only for
  // worlds on a uniform base, the only kind older files describe).
  bool matches_recorded_hash(uint64_t recorded) const;
  size_t detail_tile_count() const { return detail_.stored_count(); }
  std::vector<TileCoord> stored_detail_tiles() const;

  // --- Base and edits ---
  const TileBase& base() const { return *base_; }
  const std::shared_ptr<const TileBase>& base_ptr() const { return base_; }
  // Coarse tiles held as edited at a mip (written since the base, even if written back to the
  // base's content), sorted by (ty, tx).
  std::vector<TileCoord> edited_coarse_tiles(int32_t mip) const;
  size_t edited_coarse_tile_count() const;
  // True when every tile's version 0 is the base's tile: nothing was ever committed at
  // version 0 (a DEM's samples are, over a fill). Later edits do not change it, since they
  // have later versions; loaders of a snapshot restore it from the manifest.
  bool initial_is_base() const { return initial_is_base_; }
  void set_initial_is_base(bool v) { initial_is_base_ = v; }
  // Bytes of samples held in memory for edited coarse tiles and stored detail tiles (evicted
  // persisted tiles not counted).
  size_t edited_bytes() const;
  // Drops what is held of a mip-0 tile (a coarse tile's edited samples, or a detail tile),
  // which then reads as the base again (detail: zeros) at version 0; uncommitted marks on it
  // are dropped too. Mips above are not recomputed: for a holder of some tiles only (a
  // client's mirror), which reads only the tiles it holds and forgets the rest.
  void discard_tile(Layer layer, int32_t tx, int32_t ty);
  // commit() keeps mip 0 alone: coarser mips are neither computed nor held (their tile states
  // stay at the base's). For a holder that gets its mip tiles elsewhere (a client's mirror).
  void set_mip0_only(bool on) { mip0_only_ = on; }
  // Replaces the base by one with the same identity and samples (a decorator that prepares
  // tiles ahead, server/tile_prefetcher.h); what is cached stays.
  void replace_base(std::shared_ptr<const TileBase> base);
  // Whether reading this coarse tile now would ask the base (in range, not edited, not cached).
  bool needs_base_read(int32_t mip, int32_t tx, int32_t ty) const;
  // The clean-tile cache: its budget (bytes of samples), what it holds, how many tiles the
  // base was asked for so far, and the trim that brings it under budget (LRU first).
  void set_base_cache_budget(size_t bytes) { cache_budget_ = bytes; }
  size_t base_cache_budget() const { return cache_budget_; }
  size_t base_cache_bytes() const { return cache_bytes_; }
  uint64_t base_tiles_generated() const { return base_generated_; }
  // Brings the tiles in memory under the budget by dropping clean ones (the base's, and
  // persisted edited tiles), least recently used first. Edited tiles no store holds count
  // against the budget but stay: over budget with those alone, every clean tile goes.
  void trim_base_cache();

  // --- Persistence: edited tiles a store holds, which the world may evict and read back ---
  // The store edited tiles are read back from (null: none, nothing is evicted).
  void set_edit_source(std::shared_ptr<const EditedTileSource> source);
  bool has_edit_source() const { return source_ != nullptr; }
  // Every edited tile: coarse tiles at every mip held as edited, and detail tiles with a
  // state (changed at least once); sorted by coordinate.
  struct EditedTileInfo {
    TileCoord coord;
    TileState state;
    uint64_t base_hash = 0;  // coarse: the base's tile under it
    bool persisted = false;  // a store holds this state (mark_persisted, adopt_persisted)
  };
  std::vector<EditedTileInfo> edited_tiles() const;
  // Edited tiles whose current state no store holds, and their samples' bytes: what the next
  // snapshot must write.
  std::vector<TileCoord> unpersisted_tiles() const;
  size_t unpersisted_bytes() const;
  // The store now holds tile `c` as it was at `version`: if the tile is still at that version
  // it becomes clean (evictable). A tile changed since is left dirty.
  void mark_persisted(const TileCoord& c, uint64_t version);
  // A tile the store holds and memory does not (loading an incremental snapshot): its state,
  // the hash of the base's tile under it (coarse), and whether a detail tile has samples.
  // Needs an edit source. Returns false for a tile outside the world.
  bool adopt_persisted(const TileCoord& c, const TileState& state, uint64_t base_hash);
  // Persisted edited tiles in memory, and how many tiles were read back from the store.
  size_t resident_persisted_bytes() const { return residency_.persisted_bytes; }
  uint64_t edited_tiles_loaded() const { return residency_.loaded; }

 private:
  struct EditedTile {
    std::vector<uint16_t> data;  // empty while evicted (persisted only)
    TileState state;
    uint64_t base_hash = 0;  // hash of the base's tile: equal content hashes as untouched
    bool persisted = false;  // the store holds this state: evictable
    uint64_t last_use = 0;
  };
  struct CachedTile {
    std::vector<uint16_t> data;
    uint64_t hash = 0;
    bool hashed = false;
    uint64_t last_use = 0;
  };
  struct CoarseMip {
    RectI tiles;  // tile range at this mip
    std::unordered_map<int64_t, EditedTile> edited;
  };
  static int64_t key(int32_t tx, int32_t ty) { return tile_key(tx, ty); }
  bool tile_in_range(int32_t mip, int32_t tx, int32_t ty) const;
  void update_mips(const RectI& dirty0, std::unordered_map<TileCoord, RectI, TileCoordHash>& changed);
  // The base's tile, from the cache or generated into it (uniform bases share one tile).
  CachedTile& base_tile(int32_t mip, int32_t tx, int32_t ty) const;
  uint64_t base_tile_hash(int32_t mip, int32_t tx, int32_t ty) const;
  // The edited tile, copied from the base on first use, resident.
  EditedTile& materialize(int32_t mip, int32_t tx, int32_t ty);
  // The same, about to be written: no longer clean.
  EditedTile& writable(int32_t mip, int32_t tx, int32_t ty);
  const EditedTile* edited(int32_t mip, int32_t tx, int32_t ty) const;
  // An edited tile's samples, read back from the store if evicted.
  const std::vector<uint16_t>& resident(int32_t mip, int32_t tx, int32_t ty, const EditedTile& e) const;
  // The store of a sparse layer's tiles (layers without a base: the detail offsets). One
  // layer is sparse today; a new sparse row gets its own store here.
  template <class R>
  SparseTiles<typename R::Sample>& sparse() const {
    static_assert(std::is_same_v<R, DetailLayer>, "World holds a SparseTiles for the detail layer only");
    return detail_;
  }
  // How a sparse layer's evicted tiles are read back: from the edit source.
  auto detail_load() const {
    return [this](int32_t tx, int32_t ty, std::span<int8_t> out) { source_->read_detail_tile(tx, ty, out); };
  }
  // A detail tile's samples (nullptr: all zero), read back from the store if evicted.
  std::vector<int8_t>* detail_samples(int64_t k) const {
    return detail_.samples(k, residency_, detail_load());
  }
  // A detail tile's samples about to be written (created as zeros): no longer clean.
  std::vector<int8_t>& writable_detail(int32_t tx, int32_t ty) {
    return detail_.writable(key(tx, ty), residency_, detail_load());
  }
  void set_persisted(EditedTile& e, bool persisted);
  // Mip-0 samples of a tile in range, edited or base (through the one-tile memo).
  const uint16_t* mip0_tile(int32_t tx, int32_t ty) const;
  void add_detail_hashes(WorldHasher& h) const;

  WorldParams params_;
  RectI samples_;         // params_.sample_rect()
  RectI detail_samples_;  // params_.detail_sample_rect()
  std::shared_ptr<const TileBase> base_;
  std::vector<CoarseMip> mips_;
  mutable std::unordered_map<TileCoord, CachedTile, TileCoordHash> cache_;
  mutable CachedTile uniform_;  // the one tile of a uniform base
  mutable std::unordered_map<TileCoord, uint64_t, TileCoordHash> base_hashes_;  // never trimmed
  mutable size_t cache_bytes_ = 0;
  mutable TileResidency residency_;  // LRU clock, persisted bytes in memory, tiles read back
  mutable uint64_t base_generated_ = 0;
  size_t cache_budget_ = size_t(64) << 20;
  bool initial_is_base_ = true;
  bool mip0_only_ = false;
  // Points into this world's own tiles, so a copied or moved world starts without it.
  struct Memo {
    int32_t tx = 0, ty = 0;
    const uint16_t* data = nullptr;
    Memo() = default;
    Memo(const Memo&) {}
    Memo& operator=(const Memo&) {
      data = nullptr;
      return *this;
    }
  };
  mutable Memo memo_;
  // Detail tiles ever written, changed or adopted.
  mutable SparseTiles<int8_t> detail_;
  std::shared_ptr<const EditedTileSource> source_;
  size_t dirty_coarse_ = 0;  // edited coarse tiles no store holds at their state
  // Pending dirty rects per mip-0 tile (tile-local coordinates), merged per tile.
  std::unordered_map<TileCoord, RectI, TileCoordHash> pending_;
};

template <>
inline std::span<const uint16_t> World::tile_samples<CoarseLayer>(const TileCoord& c) const {
  return coarse_tile(c.mip, c.tx, c.ty);
}
template <>
inline std::span<const int8_t> World::tile_samples<DetailLayer>(const TileCoord& c) const {
  return detail_tile(c.tx, c.ty);
}

// World::world_hash of a world with these parameters and this content hash.
uint64_t world_hash_of(const WorldParams& params, uint64_t content_hash);

}  // namespace loam
