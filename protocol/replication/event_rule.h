// The rule both sides of the sync apply to a DeformEvent: which of its tiles a client
// reproduces itself, and whether it can apply the event now. The server's planner uses it
// to decide, per client, between "the event is enough" and "send regions"; the client's
// confirmed store uses it to apply or buffer. Written once so the two cannot drift.
//
// A per-sample stamp (every kind but the shockwave) is applied at every mip of its layer:
// a mip-m sample is the mip-0 sample at 2^m spacing, and the footprint's contact travels in
// the event (protocol/stamps/stamp_at_mip.h). A shockwave is a simulation on the mip-0 grid:
// a client runs it at mip 0 and receives the coarser mips as regions. A tile of another
// layer than the stamp's is never reproduced from the event. Pure logic.
#pragma once

#include <cstdint>
#include <optional>

#include "protocol/geometry.h"
#include "protocol/layer.h"
#include "protocol/stamps/stamp.h"
#include "protocol/wire/messages.h"

namespace loam::replication {

// True when a client holding tile c at the event's base version reproduces the stamp's change
// of c by applying the stamp there.
constexpr bool event_reproduces_tile(const QuantizedStamp& stamp, const TileCoord& c) {
  if (c.layer != stamp.layer) return false;
  return c.mip == 0 || (stamp.kind != StampKind::kShockwave && layer_info(c.layer).has_mips);
}

enum class EventFit : uint8_t {
  kApply,  // every tile it reproduces that the client holds is at the event's base version
  kWait,   // some held tile is at another version (or the event lists no tiles): buffer it,
           // regions will follow
};

// `held(tile)` returns the version the client holds of a tile, or std::nullopt when it does
// not hold it. Tiles the client does not hold are not needed: each tile's change depends only
// on that tile's samples (and, for a footprint, the contact in the event).
template <typename Held>
EventFit event_fit(const wire::DeformEvent& e, Held&& held) {
  // An event too large to list its tiles is covered by regions (the server sends them).
  if (e.base_versions.empty()) return EventFit::kWait;
  for (const wire::TileVersion& bv : e.base_versions) {
    if (!event_reproduces_tile(e.stamp, bv.tile)) continue;
    const std::optional<uint64_t> v = held(bv.tile);
    if (v && *v != bv.version) return EventFit::kWait;
  }
  return EventFit::kApply;
}

}  // namespace loam::replication
