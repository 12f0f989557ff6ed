#include "server/replication/client_tiles.h"

#include <algorithm>
#include <tuple>

#include "protocol/replication/event_rule.h"

namespace loam::server {

void ClientTiles::set_due(TileInterest& t, bool due) {
  if (t.due == due) return;
  t.due = due;
  due ? ++due_ : --due_;
}

void ClientTiles::subscribe(const TileCoord& c, std::optional<uint64_t> held, uint64_t current,
                            std::optional<RectI> changed_since_held) {
  TileInterest& t = tiles_[c];
  t.held = held;
  t.changed = {};
  t.whole = false;
  if (held && *held == current) {
    set_due(t, false);
    return;
  }
  if (held && changed_since_held && !changed_since_held->empty()) {
    t.changed = *changed_since_held;  // a patch over the held version
  } else {
    t.whole = true;
  }
  set_due(t, true);
}

void ClientTiles::unsubscribe(const TileCoord& c) {
  const auto it = tiles_.find(c);
  if (it == tiles_.end()) return;
  set_due(it->second, false);
  tiles_.erase(it);
}

const TileInterest* ClientTiles::find(const TileCoord& c) const {
  const auto it = tiles_.find(c);
  return it == tiles_.end() ? nullptr : &it->second;
}

bool ClientTiles::plan_event(const wire::DeformEvent& e, std::span<const TileChange> changes) {
  bool touches = false;
  for (const TileChange& c : changes) touches = touches || tiles_.count(c.coord);
  if (!touches) return false;
  // The client processes this event after every frame sent before it: it holds `held`.
  const bool fits = replication::event_fit(e, [&](const TileCoord& c) -> std::optional<uint64_t> {
                      const auto it = tiles_.find(c);
                      return it == tiles_.end() ? std::nullopt : it->second.held;
                    }) == replication::EventFit::kApply;
  for (const TileChange& c : changes) {
    const auto it = tiles_.find(c.coord);
    if (it == tiles_.end()) continue;
    TileInterest& t = it->second;
    if (fits && t.held == c.base_version && replication::event_reproduces_tile(e.stamp, c.coord)) {
      t.held = c.new_version;  // the client applies the stamp there itself
      continue;
    }
    // A region must go; while the client holds a version, only the samples changed since.
    if (t.held && !t.whole) {
      t.changed = t.changed.unite(c.rect);
    } else {
      t.whole = true;
    }
    set_due(t, true);
  }
  return true;
}

std::vector<TileCoord> ClientTiles::due_in_order() const {
  struct Key {
    bool focus;
    bool top;  // the coarsest level the client subscribed to: the whole view, coarsely, first
    double distance2;
    int mip;
    TileCoord tile;
  };
  int top = 0;
  for (const auto& [c, t] : tiles_) top = std::max<int>(top, c.mip);
  std::vector<Key> keys;
  keys.reserve(due_);
  for (const auto& [c, t] : tiles_) {
    if (!t.due) continue;
    double d2 = 0;
    if (focus_) {
      // From the focus to the nearest point of the tile (mip-0 samples): 0 inside it.
      const double span = double(kTileSize) * double(int64_t(1) << c.mip);
      const double x0 = double(c.tx) * span, y0 = double(c.ty) * span;
      const double dx = std::max({x0 - focus_->first, 0.0, focus_->first - (x0 + span)});
      const double dy = std::max({y0 - focus_->second, 0.0, focus_->second - (y0 + span)});
      d2 = dx * dx + dy * dy;
    }
    keys.push_back({focus_.has_value(), c.mip == top, d2, c.mip, c});
  }
  std::sort(keys.begin(), keys.end(), [](const Key& a, const Key& b) {
    // Ties (tiles at the same distance, e.g. all those holding the focus): finer first, but
    // without a focus (every distance 0) coarser first.
    return a.focus ? std::tie(b.top, a.distance2, a.mip, a.tile) < std::tie(a.top, b.distance2, b.mip, b.tile)
                   : std::tie(b.top, b.mip, a.tile) < std::tie(a.top, a.mip, b.tile);
  });
  std::vector<TileCoord> out;
  out.reserve(keys.size());
  for (const Key& k : keys) out.push_back(k.tile);
  return out;
}

RegionNeed ClientTiles::need(const TileCoord& c,
                             const std::function<bool(const TileCoord&, uint64_t)>& delta_possible) const {
  RegionNeed n;
  n.tile = c;
  n.rect = {0, 0, kTileSize, kTileSize};
  const TileInterest* t = find(c);
  if (!t || !t->held || t->whole || t->changed.empty()) return n;
  if (t->changed.area() * 4 > kTileSamples && !(delta_possible && delta_possible(c, *t->held))) return n;
  n.base = t->held;
  n.rect = t->changed;
  return n;
}

void ClientTiles::mark_sent(const TileCoord& c, uint64_t version) {
  const auto it = tiles_.find(c);
  if (it == tiles_.end()) return;
  TileInterest& t = it->second;
  t.held = version;
  t.changed = {};
  t.whole = false;
  set_due(t, false);
}

}  // namespace loam::server
