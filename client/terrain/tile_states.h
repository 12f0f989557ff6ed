// What the client knows of each tile, for the HUD's cache view: held (samples here, current as
// far as the client knows), pending (asked for, nothing arrived yet), stale (held, but an event
// the server applied waits for a region of it, so it lags the server) and evicted (held, then
// dropped as the view moved; remembered for a while so the minimap shows the cache's churn).
// Pure logic: sets of tiles go in once a frame, states come out.
#pragma once

#include <cstdint>
#include <map>
#include <span>
#include <vector>

#include "protocol/geometry.h"

namespace loam::terrain {

enum class TileState : uint8_t { kHeld, kPending, kStale, kEvicted };
inline constexpr int kTileStateCount = 4;
const char* to_string(TileState s);

struct TileStateCounts {
  int64_t held = 0, pending = 0, stale = 0, evicted = 0;
};

class TileStates {
 public:
  explicit TileStates(double evicted_memory_s = 10.0) : evicted_memory_s_(evicted_memory_s) {}

  // The store's tiles now (any order): `wanted` subscribed, `held` with samples, `behind` held
  // tiles a buffered event waits on. A tile held before and neither wanted nor held now is
  // evicted (from `now_s`, in seconds on any steady clock); wanted again, it is pending or held.
  void update(std::span<const TileCoord> wanted, std::span<const TileCoord> held,
              std::span<const TileCoord> behind, double now_s);

  // Every tile with a state, ordered by TileCoord (layer, then mip, then position).
  const std::map<TileCoord, TileState>& tiles() const { return states_; }
  TileStateCounts counts() const;

 private:
  double evicted_memory_s_;
  std::map<TileCoord, TileState> states_;
  std::map<TileCoord, double> evicted_at_;
};

}  // namespace loam::terrain
