#include "server/replication/tile_history.h"

namespace loam::server {

void TileHistory::record(std::span<const TileChange> changes) {
  if (per_tile_ == 0 || max_tiles_ == 0) return;
  for (const TileChange& c : changes) {
    auto it = tiles_.find(c.coord);
    if (it == tiles_.end()) {
      if (tiles_.size() >= max_tiles_) {
        tiles_.erase(lru_.back());
        lru_.pop_back();
      }
      lru_.push_front(c.coord);
      it = tiles_.emplace(c.coord, Entry{{}, lru_.begin()}).first;
    } else {
      lru_.splice(lru_.begin(), lru_, it->second.lru);
    }
    std::deque<TileChange>& list = it->second.changes;
    list.push_back(c);
    if (list.size() > per_tile_) list.pop_front();
  }
}

std::optional<RectI> TileHistory::changed_since(const TileCoord& c, uint64_t held) const {
  const auto it = tiles_.find(c);
  if (it == tiles_.end()) return std::nullopt;
  const std::deque<TileChange>& list = it->second.changes;
  if (!list.empty() && list.back().new_version == held) return RectI{};
  // Versions chain: each change's base is the previous one's new version. Find the change made
  // right after `held` and unite the rects from there on.
  RectI rect;
  bool found = false;
  for (const TileChange& ch : list) {
    if (ch.base_version == held) found = true;
    if (found) rect = rect.unite(ch.rect);
  }
  return found ? std::optional<RectI>(rect) : std::nullopt;
}

}  // namespace loam::server
