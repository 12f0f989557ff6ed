// PrefetchingBase: a world's base (a refined source or a tile pack) with a worker thread that
// generates or reads tiles before the tick needs them. The tick thread queues the tiles an
// admitted stamp will touch (every mip under its reach) and the tiles a subscription asks for,
// as they arrive; by the tick that applies the stamp or streams the region, the tile is ready
// and World's cache miss costs a copy instead of a refinement or a decode. Tiles not ready are
// made on the asking thread as before (one already being made is waited for, never made twice),
// so the samples never depend on timing. Memory: at most `max_ready` prepared tiles.
//
// It is a TileBase with the inner base's identity: World and the snapshots see the same base.
// Thread-safe: prefetch() and coarse_tile() from any thread.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <span>
#include <thread>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "protocol/base/tile_base.h"

namespace loam::server {

class PrefetchingBase final : public TileBase {
 public:
  struct Stats {
    uint64_t queued = 0;       // tiles accepted into the queue
    uint64_t prepared = 0;     // made by the worker
    uint64_t ready_hits = 0;   // World's misses answered by a prepared tile
    uint64_t waited = 0;       // answered by waiting for the tile being prepared
    uint64_t made_inline = 0;  // made on the asking thread (not queued, or dropped)
    uint64_t dropped = 0;      // prepared but never asked for, dropped for room
  };

  PrefetchingBase(std::shared_ptr<const TileBase> inner, size_t max_ready = 256);
  ~PrefetchingBase() override;
  PrefetchingBase(const PrefetchingBase&) = delete;
  PrefetchingBase& operator=(const PrefetchingBase&) = delete;

  void coarse_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const override;
  uint64_t identity() const override { return inner_->identity(); }
  std::string describe() const override { return inner_->describe(); }
  bool uniform() const override { return inner_->uniform(); }

  // Queues coarse tiles to prepare, in order (duplicates and tiles already queued or ready are
  // skipped; when the queue holds max_ready tiles the rest are not queued).
  void prefetch(std::span<const TileCoord> tiles) const;
  Stats stats() const;
  // Tiles prepared and not yet asked for.
  size_t ready() const;
  const std::shared_ptr<const TileBase>& inner() const { return inner_; }

 private:
  void run();

  std::shared_ptr<const TileBase> inner_;
  const size_t max_ready_;
  mutable std::mutex mu_;
  mutable std::condition_variable work_cv_, done_cv_;
  mutable std::deque<TileCoord> queue_;
  mutable std::unordered_set<TileCoord, TileCoordHash> queued_;  // in queue_ or being made
  mutable std::unordered_map<TileCoord, std::vector<uint16_t>, TileCoordHash> ready_;
  mutable std::deque<TileCoord> ready_order_;  // oldest first, for dropping
  mutable Stats stats_;
  bool stop_ = false;
  std::thread worker_;
};

}  // namespace loam::server
