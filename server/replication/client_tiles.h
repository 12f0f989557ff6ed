// The server's model of one client's tiles, and the planner that keeps it: for each tile the
// client subscribed to, the version it holds (as of the frames sent to it so far) and whether
// a region must still go. Pure logic, no I/O: the replication core drives it, and the table
// tests in tests/server/client_tiles_test.cpp pin every decision.
//
// Per applied stamp, plan_event decides for this client between "the event is enough" (each
// held tile it reproduces advances to the stamp's version, protocol/replication/event_rule.h)
// and "a region is due" for the tiles it cannot follow: a patch of the samples changed since
// the version it holds, or the whole tile when it holds none. Due regions leave later, under
// the client's byte budget, coarsest mip first and then nearest its focus (due_in_order), and
// always at the tile's newest version: several changes to a queued tile coalesce into one
// region. A client is never recorded as holding a version it was not sent (mark_sent).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <span>
#include <vector>

#include "protocol/geometry.h"
#include "protocol/wire/messages.h"
#include "protocol/world.h"

namespace loam::server {

struct TileInterest {
  std::optional<uint64_t> held;  // version the client holds once the frames sent so far arrive
  bool due = false;              // a region must still go
  RectI changed;                 // when due and held: tile-local samples changed since `held`
  bool whole = false;            // when due: the changed samples are unknown (send the tile)
};

// What a due tile needs, as planned when it is sent.
struct RegionNeed {
  TileCoord tile;
  std::optional<uint64_t> base;  // a patch over this held version; nullopt: the whole tile
  RectI rect;                    // the patch's tile-local samples (whole tile when !base)
};

class ClientTiles {
 public:
  // A subscription: `held` is the version the client says it holds (nullopt: none). A tile it
  // holds at `current` needs nothing; one held behind with `changed_since_held` known (the
  // server's tile history) needs a patch of those samples; otherwise the whole tile is due.
  void subscribe(const TileCoord& c, std::optional<uint64_t> held, uint64_t current,
                 std::optional<RectI> changed_since_held = std::nullopt);
  void unsubscribe(const TileCoord& c);
  bool subscribed(const TileCoord& c) const { return tiles_.count(c) != 0; }
  size_t size() const { return tiles_.size(); }
  const TileInterest* find(const TileCoord& c) const;

  // Plans one applied stamp for this client. Returns true when the stamp touches a tile the
  // client subscribed to (it then gets the event); updates held versions and due regions.
  bool plan_event(const wire::DeformEvent& e, std::span<const TileChange> changes);

  // Tiles with a region due, in the order they should leave: the coarsest level subscribed
  // first (the whole view shows at once, coarsely), then nearest the focus (world sample
  // coordinates at mip 0; distance to the tile's nearest point), finer first among equals.
  // The display shows the finest tile it holds at each point, so the tiles under the viewer
  // come first and coarser tiles reach farther for the same distance: the view's error falls
  // fastest where it is seen largest. Without a focus: coarsest mip first.
  void set_focus(std::optional<std::pair<double, double>> focus_samples) { focus_ = focus_samples; }
  std::vector<TileCoord> due_in_order() const;
  size_t due_count() const { return due_; }
  // What the due tile c needs now: a patch when the client holds a version and either the
  // changed samples are at most a quarter of the tile or `delta_possible(c, held)` (the server
  // can code the patch against the held samples, which beats the whole tile at any size);
  // else the whole tile.
  RegionNeed need(const TileCoord& c,
                  const std::function<bool(const TileCoord&, uint64_t)>& delta_possible = {}) const;
  // The region for c at `version` was sent: the client will hold it.
  void mark_sent(const TileCoord& c, uint64_t version);

  // Every subscribed tile (TileHashes go for all of them).
  const std::map<TileCoord, TileInterest>& tiles() const { return tiles_; }

 private:
  void set_due(TileInterest& t, bool due);

  std::map<TileCoord, TileInterest> tiles_;
  size_t due_ = 0;
  std::optional<std::pair<double, double>> focus_;
};

}  // namespace loam::server
