// Streaming, part of ReplicationCore: subscriptions (deferred while an apply runs), and each
// tick with the world free the regions due under each client's byte budget (coarsest mip
// first, nearest its focus, encoded once for all) and the TileHashes rounds.
#include <algorithm>

#include "server/replication/core_detail.h"
#include "server/replication/replication_core.h"

namespace loam::server {

using namespace core_detail;

namespace {

// Untouched tiles a hashes round may generate (or read from a pack) to hash them: about 4 ms
// of refinement. A roaming client's new tiles would otherwise all be made in one tick.
constexpr uint32_t kHashBaseReadsPerRound = 16;

}  // namespace

bool ReplicationCore::valid_tile(const TileCoord& t) const {
  const WorldParams& p = terrain_.world().params();
  if (t.layer == Layer::kCoarse) return t.mip < p.mip_count() && p.tile_range(t.mip).contains(t.tx, t.ty);
  return t.mip == 0 && tiles_overlapping(p.detail_sample_rect()).contains(t.tx, t.ty);
}

void ReplicationCore::receive_subscription(Client& c, const wire::Message& m) {
  if (applier_->busy() || !deferred_subscriptions_.empty()) {
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
      if (e.tile.layer == Layer::kCoarse && valid_tile(e.tile) &&
          terrain_.world().needs_base_read(e.tile.mip, e.tile.tx, e.tile.ty))
        ahead.push_back(e.tile);
    }
    prefetch_->prefetch(ahead);
  }
}

void ReplicationCore::stream(CoreTime now, const std::function<uint64_t(ClientId)>& unsent) {
  if (stopping_ || failed_) return;
  run_deferred_subscriptions();
  frames_.adopt_best();
  stream_regions(now, unsent);
  if (config_.hashes_every_ticks > 0 && tick_ % config_.hashes_every_ticks == 0) {
    uint32_t base_reads_left = kHashBaseReadsPerRound;
    std::vector<TileCoord> later;
    for (auto& [id, c] : clients_) {
      if (c.state == Client::State::kReady && c.tiles.size() != 0) send_hashes(c, base_reads_left, later);
    }
    if (prefetch_ && !later.empty()) prefetch_->prefetch(later);
  }
}

void ReplicationCore::stream_regions(CoreTime now, const std::function<uint64_t(ClientId)>& unsent) {
  // Every client's turn in a rotating order; within a client, its due tiles in order, while
  // its byte budget has credit. Encodes (cache misses) are bounded per tick for everyone.
  std::vector<ClientId> order;
  for (auto& [id, c] : clients_) {
    if (c.state == Client::State::kReady) order.push_back(id);
  }
  if (order.empty()) return;
  std::rotate(order.begin(), order.begin() + ptrdiff_t(stream_cursor_ % order.size()), order.end());
  ++stream_cursor_;
  const double budget = double(config_.client_bytes_per_second);
  uint32_t encodes_left = config_.max_encodes_per_tick;
  for (const ClientId id : order) {
    Client& c = clients_.at(id);
    c.credit.refill(now);
    if (c.tiles.due_count() == 0) continue;
    // A client that does not read gets no more bulk: only what must go.
    const uint64_t queued = unsent ? unsent(id) : 0;
    if (budget > 0 && double(queued) > budget) continue;
    for (const TileCoord& t : c.tiles.due_in_order()) {
      if (budget > 0 && c.credit.level() <= 0) break;
      const RegionNeed need = c.tiles.need(
          t, [&](const TileCoord& tile, uint64_t held) { return history_.can_rebuild(tile, held); });
      Frames frames;
      if (encodes_left == 0) {
        // Out of encodes this tick: only what the cache already holds may still go.
        frames = frames_.cached(terrain_.world(), t, need.base, need.rect);
        if (frames.empty()) break;
      } else {
        bool encoded = false;
        auto got = frames_.get(terrain_.world(), &history_, t, need.base, need.rect, &encoded);
        if (encoded) --encodes_left;
        if (!got) {
          note("encode_error", {{"tile", to_string(t)}, {"error", got.error().describe()}});
          c.tiles.unsubscribe(t);  // cannot be served: stop planning it rather than retry forever
          continue;
        }
        frames = std::move(*got);
      }
      for (const FramePtr& f : frames) {
        send_frame(id, f);
        c.credit.spend(double(f->size()));
      }
      c.tiles.mark_sent(t, terrain_.world().tile_state(t).version);
      ++stats_.regions_sent;
      if (need.base) ++stats_.partial_regions_sent;
    }
  }
}

void ReplicationCore::send_hashes(Client& c, uint32_t& base_reads_left, std::vector<TileCoord>& later) {
  wire::TileHashes msg;
  for (const auto& [t, interest] : c.tiles.tiles()) {
    // An untouched tile whose hash is not known costs a generation or a pack read: the round
    // makes a few, and the rest are made ahead and hashed in a later round.
    std::optional<TileState> st = terrain_.world().known_tile_state(t);
    if (!st) {
      if (base_reads_left == 0) {
        later.push_back(t);
        continue;
      }
      --base_reads_left;
      st = terrain_.world().tile_state(t);
    }
    msg.entries.push_back({t, st->version, st->hash});
    if (msg.entries.size() == wire::kMaxTileHashEntries) {
      send(c, msg);
      msg.entries.clear();
    }
  }
  if (!msg.entries.empty()) send(c, msg);
}

}  // namespace loam::server
