#include "client/terrain/tile_states.h"

#include <set>

namespace loam::terrain {

const char* to_string(TileState s) {
  switch (s) {
    case TileState::kHeld: return "held";
    case TileState::kPending: return "pending";
    case TileState::kStale: return "stale";
    case TileState::kEvicted: return "evicted";
  }
  return "?";
}

void TileStates::update(std::span<const TileCoord> wanted, std::span<const TileCoord> held,
                        std::span<const TileCoord> behind, double now_s) {
  const std::set<TileCoord> held_set(held.begin(), held.end()), behind_set(behind.begin(), behind.end());
  std::map<TileCoord, TileState> next;
  for (const TileCoord& c : held) next[c] = behind_set.count(c) ? TileState::kStale : TileState::kHeld;
  for (const TileCoord& c : wanted) {
    if (!held_set.count(c)) next[c] = TileState::kPending;
  }
  // Held last frame and gone now: evicted from now on.
  for (const auto& [c, s] : states_) {
    if (s != TileState::kEvicted && s != TileState::kPending && !next.count(c)) evicted_at_[c] = now_s;
  }
  for (auto it = evicted_at_.begin(); it != evicted_at_.end();) {
    if (next.count(it->first) || now_s - it->second > evicted_memory_s_) {
      it = evicted_at_.erase(it);
    } else {
      next.emplace(it->first, TileState::kEvicted);
      ++it;
    }
  }
  states_ = std::move(next);
}

TileStateCounts TileStates::counts() const {
  TileStateCounts n;
  for (const auto& [c, s] : states_) {
    switch (s) {
      case TileState::kHeld: ++n.held; break;
      case TileState::kPending: ++n.pending; break;
      case TileState::kStale: ++n.stale; break;
      case TileState::kEvicted: ++n.evicted; break;
    }
  }
  return n;
}

}  // namespace loam::terrain
