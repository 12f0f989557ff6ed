// Which samples of a tile changed since a version, and what they were: the last changes of
// recently changed tiles (base version, new version, changed rect, and the samples the change
// replaced), bounded per tile, in tiles and in bytes. A client resuming behind a tile's current
// version then receives only the samples changed since the version it holds, coded as a delta
// against what it holds (kDelta), not the whole tile. Pure: no I/O.
#pragma once

#include <cstdint>
#include <deque>
#include <list>
#include <map>
#include <optional>
#include <span>
#include <vector>

#include "protocol/geometry.h"
#include "protocol/world.h"

namespace loam::server {

// Samples of one tile, read before a stamp changes them.
struct TileSamples {
  TileCoord tile;
  RectI rect;                    // tile-local, inside [0, kTileSize)^2
  std::vector<uint16_t> coarse;  // coarse tiles: rect.area() samples, row-major
  std::vector<int8_t> detail;    // detail tiles: rect.area() samples, row-major
};

// The samples of every tile a stamp reaching `reach0` (its layer's mip-0 global sample grid,
// stamp_reach) may change, at every mip for the coarse layer: what World::commit's changes
// will cover. Empty when they would exceed `max_samples` (too large to keep: the changes are
// then recorded without them).
std::vector<TileSamples> read_reach(const World& world, Layer layer, const RectI& reach0,
                                    uint64_t max_samples);

class TileHistory {
 public:
  // Keeps up to `changes_per_tile` changes of each of up to `max_tiles` tiles, and up to
  // `max_bytes` of replaced samples (the least recently changed tiles are forgotten first).
  TileHistory(size_t changes_per_tile, size_t max_tiles, uint64_t max_bytes = 32ull << 20)
      : per_tile_(changes_per_tile), max_tiles_(max_tiles), max_bytes_(max_bytes) {}

  // Records commit changes; `before` (read_reach before the stamp) gives the samples each
  // change replaced, where it covers the change's rect.
  void record(std::span<const TileChange> changes, std::span<const TileSamples> before = {});
  // The tile-local rect of the samples of c changed after version `held` up to its current
  // version, when the history reaches back to `held`; nullopt when it does not (send it whole).
  // An empty rect: nothing changed since `held`.
  std::optional<RectI> changed_since(const TileCoord& c, uint64_t held) const;
  // The samples of `rect` (which must contain changed_since(c, held)) as they were at version
  // `held`, given the same rect's samples now (`current`): every change since `held` undone,
  // newest first. nullopt when the history does not reach `held` or lacks a change's samples.
  // R: c's layer row (protocol/layer.h).
  template <class R>
  std::optional<std::vector<typename R::Sample>> samples_at(
      const TileCoord& c, uint64_t held, const RectI& rect,
      std::span<const typename R::Sample> current) const;
  // Whether samples_at can rebuild c's samples at `held` (no copy made).
  bool can_rebuild(const TileCoord& c, uint64_t held) const;

  size_t tiles() const { return tiles_.size(); }
  uint64_t bytes() const { return bytes_; }  // replaced samples held

 private:
  struct Change {
    TileChange change;
    bool kept = false;  // the replaced samples below are complete
    std::vector<uint16_t> coarse;
    std::vector<int8_t> detail;
    uint64_t bytes() const { return coarse.size() * sizeof(uint16_t) + detail.size(); }
  };
  struct Entry {
    std::deque<Change> changes;  // oldest first
    std::list<TileCoord>::iterator lru;
  };
  void forget(std::map<TileCoord, Entry>::iterator it);

  size_t per_tile_, max_tiles_;
  uint64_t max_bytes_;
  uint64_t bytes_ = 0;
  std::map<TileCoord, Entry> tiles_;
  std::list<TileCoord> lru_;  // most recently changed first
};

}  // namespace loam::server
