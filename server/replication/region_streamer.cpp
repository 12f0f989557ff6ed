#include "server/replication/region_streamer.h"

#include <algorithm>

namespace loam::server {

RegionStreamer::RegionStreamer(const ServerConfig& config)
    : frames_(config.region_cache_bytes, config.best_after_uses),
      budget_(double(config.client_bytes_per_second)),
      max_encodes_(config.max_encodes_per_tick) {}

TokenBucket RegionStreamer::credit(CoreTime now) const { return TokenBucket(budget_, budget_, 0.0, now); }

BulkRound RegionStreamer::stream(std::span<const BulkClient> clients, const World& world,
                                 const TileHistory& history, CoreTime now,
                                 const std::function<uint64_t(uint32_t)>& unsent,
                                 const std::function<void(uint32_t, FramePtr)>& send) {
  BulkRound round;
  if (clients.empty()) return round;
  std::vector<BulkClient> order(clients.begin(), clients.end());
  std::rotate(order.begin(), order.begin() + ptrdiff_t(cursor_ % order.size()), order.end());
  ++cursor_;
  uint32_t encodes_left = max_encodes_;
  for (const BulkClient& c : order) {
    c.credit->refill(now);
    if (c.tiles->due_count() == 0) continue;
    // A client that does not read gets no more bulk: only what must go.
    const uint64_t queued = unsent ? unsent(c.id) : 0;
    if (budget_ > 0 && double(queued) > budget_) continue;
    for (const TileCoord& t : c.tiles->due_in_order()) {
      if (budget_ > 0 && c.credit->level() <= 0) break;
      const RegionNeed need = c.tiles->need(
          t, [&](const TileCoord& tile, uint64_t held) { return history.can_rebuild(tile, held); });
      Frames frames;
      if (encodes_left == 0) {
        // Out of encodes this tick: only what the cache already holds may still go.
        frames = frames_.cached(world, t, need.base, need.rect);
        if (frames.empty()) break;
      } else {
        bool encoded = false;
        auto got = frames_.get(world, &history, t, need.base, need.rect, &encoded);
        if (encoded) --encodes_left;
        if (!got) {
          round.failed.emplace_back(t, got.error());
          c.tiles->unsubscribe(t);  // cannot be served: stop planning it rather than retry forever
          continue;
        }
        frames = std::move(*got);
      }
      for (const FramePtr& f : frames) {
        c.credit->spend(double(f->size()));
        send(c.id, f);
      }
      c.tiles->mark_sent(t, world.tile_state(t).version);
      ++round.regions;
      if (need.base) ++round.partial_regions;
    }
  }
  return round;
}

}  // namespace loam::server
