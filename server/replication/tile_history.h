// Which samples of a tile changed since a version: the last changes of recently changed tiles
// (base version, new version, changed rect), bounded per tile and in tiles. A client resuming
// behind a tile's current version then receives only the samples changed since the version it
// holds (a patch over it), not the whole tile. Pure; a few dozen bytes per change.
#pragma once

#include <cstdint>
#include <deque>
#include <list>
#include <map>
#include <optional>
#include <span>

#include "protocol/geometry.h"
#include "protocol/world.h"

namespace loam::server {

class TileHistory {
 public:
  // Keeps up to `changes_per_tile` changes of each of up to `max_tiles` tiles (the least
  // recently changed tiles are forgotten first).
  TileHistory(size_t changes_per_tile, size_t max_tiles)
      : per_tile_(changes_per_tile), max_tiles_(max_tiles) {}

  void record(std::span<const TileChange> changes);
  // The tile-local rect of the samples of c changed after version `held` up to its current
  // version, when the history reaches back to `held`; nullopt when it does not (send it whole).
  // An empty rect: nothing changed since `held`.
  std::optional<RectI> changed_since(const TileCoord& c, uint64_t held) const;
  size_t tiles() const { return tiles_.size(); }

 private:
  struct Entry {
    std::deque<TileChange> changes;  // oldest first
    std::list<TileCoord>::iterator lru;
  };
  size_t per_tile_, max_tiles_;
  std::map<TileCoord, Entry> tiles_;
  std::list<TileCoord> lru_;  // most recently changed first
};

}  // namespace loam::server
