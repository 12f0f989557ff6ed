// Streaming, part of ReplicationCore: subscriptions (deferred while an apply runs), and each
// tick with the world free a bulk round (region_streamer.h) and a TileHashes round
// (tile_hash_round.h) over the clients in session.
#include <algorithm>

#include "server/replication/core_detail.h"
#include "server/replication/replication_core.h"
#include "server/replication/tile_hash_round.h"

namespace loam::server {

using namespace core_detail;

bool ReplicationCore::valid_tile(const TileCoord& t) const {
  return layer_tile_range(terrain_.world().params(), t.layer, t.mip).contains(t.tx, t.ty);
}

void ReplicationCore::receive_subscription(Client& c, const wire::Message& m) {
  if (commits_.busy() || !deferred_subscriptions_.empty()) {
    deferred_subscriptions_.emplace_back(c.id, m);
    return;
  }
  if (const auto* sub = std::get_if<wire::Subscribe>(&m)) {
    on_subscribe(c, *sub);
    return;
  }
  for (const TileCoord& t : std::get<wire::Unsubscribe>(m).tiles) c.tiles.unsubscribe(t);
}

void ReplicationCore::run_deferred_subscriptions() {
  for (const auto& [id, m] : std::exchange(deferred_subscriptions_, {})) {
    const auto it = clients_.find(id);
    if (it != clients_.end() && it->second.state == Client::State::kReady)
      receive_subscription(it->second, m);
  }
}

void ReplicationCore::on_subscribe(Client& c, const wire::Subscribe& sub) {
  if (sub.focus) {
    const double mps = terrain_.world().params().meters_per_sample;
    c.tiles.set_focus(std::make_pair(sub.focus->x_m / mps, sub.focus->y_m / mps));
  }
  for (const wire::SubscribeEntry& e : sub.entries) {
    if (!valid_tile(e.tile)) {
      violation(c, wire::WireErrorCode::kOutOfWorld, "subscribe.tile",
                "tile " + to_string(e.tile) + " is not in the world");
      continue;
    }
    if (!c.tiles.subscribed(e.tile) && c.tiles.size() >= config_.max_subscriptions) {
      violation(c, wire::WireErrorCode::kOversize, "subscribe.entries",
                "subscription cap of " + std::to_string(config_.max_subscriptions) + " tiles reached");
      return;
    }
    // A client that already holds the current version (the initial terrain's 0 included)
    // resumes without a transfer; otherwise the whole tile is due (it leaves under the budget).
    const std::optional<uint64_t> held = e.held ? std::optional<uint64_t>(e.held_version) : std::nullopt;
    // Resuming behind: only the samples changed since, when the history reaches back that far.
    c.tiles.subscribe(e.tile, held, terrain_.world().tile_version(e.tile),
                      held ? history_.changed_since(e.tile, *held) : std::nullopt);
  }
  // The tiles this subscription will read (hashes, regions) get made ahead, off this thread.
  if (prefetch_) {
    std::vector<TileCoord> ahead;
    for (const wire::SubscribeEntry& e : sub.entries) {
      if (layer_info(e.tile.layer).has_base && valid_tile(e.tile) &&
          terrain_.world().needs_base_read(e.tile.mip, e.tile.tx, e.tile.ty))
        ahead.push_back(e.tile);
    }
    prefetch_->prefetch(ahead);
  }
}

void ReplicationCore::stream(CoreTime now, const std::function<uint64_t(ClientId)>& unsent) {
  if (stopping_ || failed_) return;
  run_deferred_subscriptions();
  streamer_.frames().adopt_best();
  stream_regions(now, unsent);
  if (config_.hashes_every_ticks > 0 && tick_ % config_.hashes_every_ticks == 0) send_hashes();
}

void ReplicationCore::stream_regions(CoreTime now, const std::function<uint64_t(ClientId)>& unsent) {
  std::vector<BulkClient> ready;
  for (auto& [id, c] : clients_) {
    if (c.state == Client::State::kReady) ready.push_back({id, &c.tiles, &c.credit});
  }
  const BulkRound round = streamer_.stream(ready, terrain_.world(), history_, now, unsent,
                                           [&](ClientId id, FramePtr f) { send_frame(id, std::move(f)); });
  for (const auto& [tile, error] : round.failed)
    note("encode_error", {{"tile", to_string(tile)}, {"error", error.describe()}});
  stats_.regions_sent += round.regions;
  stats_.partial_regions_sent += round.partial_regions;
}

void ReplicationCore::send_hashes() {
  TileHashRound round;
  for (auto& [id, c] : clients_) {
    if (c.state != Client::State::kReady || c.tiles.size() == 0) continue;
    for (const wire::TileHashes& msg : round.hashes(c.tiles, terrain_.world())) send(c, msg);
  }
  if (prefetch_ && !round.later().empty()) prefetch_->prefetch(round.later());
}

}  // namespace loam::server
