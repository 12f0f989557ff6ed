// The client's confirmed store: the tiles it holds, each at a known server version, changed
// only in sequence order — the state that is hashed and compared with the server's.
//
// Rules (ARCHITECTURE.md, Sync): a DeformEvent is applied with the shared CPU stamp code when
// protocol/replication/event_rule.h says it fits: every tile the event reproduces that the
// store holds is at exactly the listed base version. A per-sample stamp is applied to every
// held tile of its layer at every mip (mip-m samples evaluated at their mip-0 positions, the
// footprint with the contact the event carries); a shockwave at mip 0 only. Otherwise the
// event is buffered. A RegionUpdate at version v replaces a tile; buffered events at or below
// v are dropped (the server covers their effect with regions) and the rest are tried again.
// Pure logic: no sockets; the stamp arithmetic is protocol/'s.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <span>
#include <utility>
#include <vector>

#include "protocol/layer.h"
#include "protocol/result.h"
#include "protocol/stamps/texture_registry.h"
#include "protocol/wire/messages.h"
#include "protocol/world.h"

namespace loam::client {

enum class EventOutcome { kApplied, kBuffered, kIgnored };

// One change to the store's samples, in the order they happened, for a display that mirrors
// the store (client/terrain/display_terrain.h). Recorded only when enabled.
struct StoreChange {
  enum class Kind : uint8_t { kEvent, kRegion };
  Kind kind = Kind::kEvent;
  uint64_t seq = 0;  // event: its global sequence; region: the tile's new version
  TileCoord tile;    // region: the tile replaced
  Layer layer = Layer::kCoarse;
  // Samples that changed, in the layer's global grid at mip `tile.mip` (events: mip 0 of the
  // stamp's layer; empty when the event changed nothing). An event's changes to held mip > 0
  // tiles are recorded as kRegion changes of those tiles (their samples are read from here).
  RectI rect;
  QuantizedStamp stamp;           // event: the stamp applied
  uint32_t origin_client_id = 0;  // event: who sent it
};

struct StoreCounters {
  uint64_t events_applied = 0, events_buffered = 0, events_dropped = 0;
  uint64_t regions = 0;
  uint64_t regions_partial = 0;   // of `regions`: only the changed samples of a tile
  uint64_t regions_unwanted = 0;  // arrived after the tile was unsubscribed: dropped
  uint64_t hash_checks = 0, hash_mismatches = 0;
};

class ConfirmedStore {
 public:
  explicit ConfirmedStore(const WorldParams& params);

  // The client wants this tile; it is not held until its first region arrives.
  void want(const TileCoord& c) { wanted_[c] = true; }
  bool wanted_tile(const TileCoord& c) const { return wanted_.count(c) != 0; }
  void forget(const TileCoord& c);

  // Replaces a whole tile of row R's layer (CoarseLayer, DetailLayer: protocol/layer.h) with
  // decoded samples at `version` (65536 of the row's samples). Errors: not a whole tile, not a
  // tile of that layer in the world.
  template <class R>
  Status replace(const TileCoord& c, uint64_t version, std::span<const typename R::Sample> samples);

  // Replaces the samples `rect` (tile-local) of a tile held at exactly `base`, which then is at
  // `version` (a region that sends only what changed). Errors: not held at `base`, a rect
  // outside the tile, the wrong sample count, not a tile of row R's layer.
  template <class R>
  Status patch(const TileCoord& c, const RectI& rect, uint64_t base, uint64_t version,
               std::span<const typename R::Sample> samples);
  // The held samples of `rect` (tile-local) of a tile (the base a delta-coded region needs);
  // empty when the tile is not held.
  template <class R>
  std::vector<typename R::Sample> held_rect(const TileCoord& c, const RectI& rect) const;
  // A whole region (its chunks assembled into `payload`): decoded, a patch against the
  // samples this store holds, then replace_* or patch_* of the region's layer.
  Status apply_region(const wire::RegionUpdate& r, std::span<const uint8_t> payload);

  // A texture stamp whose image is not in `textures` is buffered until it is (the server
  // applied it, so nothing else would bring its effect); the ids waited for are listed here.
  EventOutcome on_event(const wire::DeformEvent& e, const TextureRegistry* textures = nullptr);
  std::vector<uint64_t> take_missing_textures() {
    std::vector<uint64_t> out(missing_textures_.begin(), missing_textures_.end());
    missing_textures_.clear();
    return out;
  }
  // Images were registered: buffered events try again.
  void textures_arrived(const TextureRegistry* textures);
  // Held tiles that buffered texture stamps with this image wait on (to re-request them
  // whole when the image cannot be had).
  std::vector<TileCoord> tiles_waiting_for(uint64_t texture_id) const;

  // Held tiles a buffered event changes: the server has moved past the version held, and a
  // region (or an earlier event) must come before they are current again. Sorted, unique.
  std::vector<TileCoord> tiles_behind() const;

  // Compares held tiles at the same version with the server's hashes; returns mismatches.
  std::vector<TileCoord> check_hashes(const wire::TileHashes& h);

  std::optional<uint64_t> version(const TileCoord& c) const;
  uint64_t hash(const TileCoord& c) const;  // of the held samples (0 if not held)
  std::vector<TileCoord> held() const;
  // Bytes of samples held: the mirror's tiles, the held coarser mip tiles and the kept
  // version-0 copies.
  size_t held_bytes() const {
    return mirror_.edited_bytes() + (mip_tiles_.size() + initial_.size()) * kTileSamples * 2;
  }
  // Every tile the client asked for (held or still awaiting its first region).
  std::vector<TileCoord> wanted() const;
  size_t buffered() const { return buffer_.size(); }
  bool is_buffered(uint64_t global_seq) const { return buffer_.count(global_seq) != 0; }
  bool holds(const TileCoord& c) const { return versions_.count(c) != 0; }
  // The mip-0 samples of both layers; only held tiles are meaningful.
  const World& mirror() const { return mirror_; }

  // Keeps, from now on, the samples each held mip-0 coarse tile had at version 0 when it
  // first changes while held (an event, a region, a patch): the session's initial terrain
  // where it was edited in view, for a display that shows dug ground but cannot generate the
  // initial terrain (an imported DEM). Off by default; the copies go with their tiles.
  void keep_initial(bool on) { keep_initial_ = on; }
  bool keeps_initial() const { return keep_initial_; }
  // The version-0 samples of held mip-0 coarse tile (tx, ty): its own while it is at version
  // 0, the kept copy once it changed while held; empty when not known (not held, or first
  // held past version 0).
  std::span<const uint16_t> initial_coarse(int32_t tx, int32_t ty) const;
  size_t initial_tiles_kept() const { return initial_.size(); }

  // Changes are recorded from now on (off by default: bots and tests need none).
  void record_changes(bool on) { record_changes_ = on; }
  // The changes since the last call, oldest first.
  std::vector<StoreChange> take_changes() { return std::exchange(changes_, {}); }
  const StoreCounters& counters() const { return counters_; }
  // Samples of a held coarse tile (empty span if not held).
  std::span<const uint16_t> coarse_samples(const TileCoord& c) const;

 private:
  bool try_apply(const wire::DeformEvent& e, const TextureRegistry* textures);
  void retry_buffered(const TextureRegistry* textures);
  void discard_unheld(Layer layer, const RectI& rect);
  void after_region(uint64_t version);
  void keep_initial_of(const TileCoord& c);  // before tile c's samples change
  void record_region(const TileCoord& c, uint64_t version, const RectI& local);
  Status check_patch(const TileCoord& c, const RectI& rect, uint64_t base, uint64_t version,
                     size_t samples) const;

  World mirror_;                            // mip-0 samples of both layers; only held tiles are meaningful
  std::map<TileCoord, uint64_t> versions_;  // held tiles
  std::map<TileCoord, std::vector<uint16_t>> mip_tiles_;  // held coarse tiles at mip > 0
  std::map<TileCoord, bool> wanted_;
  std::map<uint64_t, wire::DeformEvent> buffer_;  // by global sequence
  const TextureRegistry* last_textures_ = nullptr;
  StoreCounters counters_;
  std::set<uint64_t> missing_textures_;
  bool record_changes_ = false;
  std::vector<StoreChange> changes_;
  bool keep_initial_ = false;
  std::map<std::pair<int32_t, int32_t>, std::vector<uint16_t>> initial_;  // mip-0 coarse, by tile
};

}  // namespace loam::client
