// Bulk streaming: each tick with the world free, the regions due to each client leave under
// its byte budget. Clients take turns in a rotating order so none always goes first; within a
// client its due tiles go coarsest mip first, then nearest its focus (ClientTiles), at the
// tile's newest version, encoded once for every client that needs the same bytes
// (region_frames.h), with a bound on encodes per tick so a join storm cannot stall the tick.
// A client whose socket is not taking what it was sent gets no more until it does.
//
// It owns the region cache and the turn order; the clients' tiles and credit are the core's,
// lent for the round. Frames leave through `send`.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <utility>
#include <vector>

#include "protocol/world.h"
#include "server/replication/client_tiles.h"
#include "server/replication/core_time.h"
#include "server/replication/region_frames.h"
#include "server/replication/tile_history.h"
#include "server/replication/token_bucket.h"
#include "server/server_config.h"

namespace loam::server {

// A client in session, for one round.
struct BulkClient {
  uint32_t id = 0;
  ClientTiles* tiles = nullptr;
  TokenBucket* credit = nullptr;  // its bulk bytes (credit())
};

// What a round sent, and the tiles it could not encode (no longer planned for their client).
struct BulkRound {
  uint64_t regions = 0, partial_regions = 0;
  std::vector<std::pair<TileCoord, Error>> failed;
};

class RegionStreamer {
 public:
  explicit RegionStreamer(const ServerConfig& config);

  // A new client's credit: it accrues at the client's budget, up to one second's worth (a
  // short burst after idling), and starts empty.
  TokenBucket credit(CoreTime now) const;
  // One round. `unsent(id)`: bytes queued for the client and not yet written (null: none).
  BulkRound stream(std::span<const BulkClient> clients, const World& world, const TileHistory& history,
                   CoreTime now, const std::function<uint64_t(uint32_t)>& unsent,
                   const std::function<void(uint32_t, FramePtr)>& send);

  RegionFrames& frames() { return frames_; }
  const RegionFrames& frames() const { return frames_; }

 private:
  RegionFrames frames_;
  double budget_;  // bytes a second per client (0: no limit)
  uint32_t max_encodes_;
  size_t cursor_ = 0;  // whose turn is first
};

}  // namespace loam::server
