// A TileHashes round: each client in session is told the version and hash of every tile it
// subscribes to, so it can find and repair what it holds wrong. An untouched tile whose hash
// is not known yet costs a generation or a pack read, so a round reads a few (shared by all
// clients of the round) and leaves the rest for a later round, to be made ahead meanwhile.
#pragma once

#include <cstdint>
#include <vector>

#include "protocol/wire/messages.h"
#include "protocol/world.h"
#include "server/replication/client_tiles.h"

namespace loam::server {

class TileHashRound {
 public:
  // About 4 ms of refinement: a roaming client's new tiles would otherwise all be made in one
  // tick.
  static constexpr uint32_t kBaseReadsPerRound = 16;

  explicit TileHashRound(uint32_t base_reads = kBaseReadsPerRound) : base_reads_left_(base_reads) {}

  // One client's messages (each at most wire::kMaxTileHashEntries entries; none when it has
  // no tile this round can hash).
  std::vector<wire::TileHashes> hashes(const ClientTiles& tiles, const World& world);
  // The tiles left for a later round (their base tiles should be made ahead).
  const std::vector<TileCoord>& later() const { return later_; }

 private:
  uint32_t base_reads_left_;
  std::vector<TileCoord> later_;
};

}  // namespace loam::server
