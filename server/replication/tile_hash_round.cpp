#include "server/replication/tile_hash_round.h"

namespace loam::server {

std::vector<wire::TileHashes> TileHashRound::hashes(const ClientTiles& tiles, const World& world) {
  std::vector<wire::TileHashes> out;
  wire::TileHashes msg;
  for (const auto& [t, interest] : tiles.tiles()) {
    std::optional<TileState> st = world.known_tile_state(t);
    if (!st) {
      if (base_reads_left_ == 0) {
        later_.push_back(t);
        continue;
      }
      --base_reads_left_;
      st = world.tile_state(t);
    }
    msg.entries.push_back({t, st->version, st->hash});
    if (msg.entries.size() == wire::kMaxTileHashEntries) out.push_back(std::exchange(msg, {}));
  }
  if (!msg.entries.empty()) out.push_back(std::move(msg));
  return out;
}

}  // namespace loam::server
