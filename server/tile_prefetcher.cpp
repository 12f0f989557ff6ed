#include "server/tile_prefetcher.h"

#include "protocol/layer.h"

#include <algorithm>

namespace loam::server {

PrefetchingBase::PrefetchingBase(std::shared_ptr<const TileBase> inner, size_t max_ready)
    : inner_(std::move(inner)), max_ready_(std::max<size_t>(1, max_ready)) {
  worker_ = std::thread([this] { run(); });
}

PrefetchingBase::~PrefetchingBase() {
  {
    std::lock_guard lock(mu_);
    stop_ = true;
  }
  work_cv_.notify_all();
  worker_.join();
}

void PrefetchingBase::prefetch(std::span<const TileCoord> tiles) const {
  bool added = false;
  {
    std::lock_guard lock(mu_);
    for (const TileCoord& c : tiles) {
      if (!layer_info(c.layer).has_base) continue;
      if (queue_.size() >= max_ready_) break;
      if (queued_.count(c) || ready_.count(c)) continue;
      queue_.push_back(c);
      queued_.insert(c);
      ++stats_.queued;
      added = true;
    }
  }
  if (added) work_cv_.notify_one();
}

void PrefetchingBase::run() {
  std::vector<uint16_t> tile(kTileSamples);
  std::unique_lock lock(mu_);
  for (;;) {
    work_cv_.wait(lock, [&] { return stop_ || !queue_.empty(); });
    if (stop_) return;
    const TileCoord c = queue_.front();
    queue_.pop_front();
    lock.unlock();
    inner_->coarse_tile(c.mip, c.tx, c.ty, tile);
    lock.lock();
    queued_.erase(c);
    // Room first: the oldest prepared tiles nobody asked for go.
    while (ready_.size() >= max_ready_ && !ready_order_.empty()) {
      ready_.erase(ready_order_.front());
      ready_order_.pop_front();
      ++stats_.dropped;
    }
    ready_.emplace(c, tile);
    ready_order_.push_back(c);
    ++stats_.prepared;
    done_cv_.notify_all();
  }
}

void PrefetchingBase::coarse_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const {
  const TileCoord c{Layer::kCoarse, uint8_t(mip), tx, ty};
  {
    std::unique_lock lock(mu_);
    // Being made, or queued: wait for it rather than make it twice. A queued tile is taken out
    // of the queue and made here if the worker has not started it.
    if (queued_.count(c)) {
      const auto q = std::find(queue_.begin(), queue_.end(), c);
      if (q != queue_.end()) {
        queue_.erase(q);
        queued_.erase(c);
      } else {
        done_cv_.wait(lock, [&] { return !queued_.count(c); });
        ++stats_.waited;
      }
    }
    if (const auto it = ready_.find(c); it != ready_.end()) {
      std::copy(it->second.begin(), it->second.end(), out.begin());
      ready_.erase(it);  // World caches it from here on
      ready_order_.erase(std::find(ready_order_.begin(), ready_order_.end(), c));
      ++stats_.ready_hits;
      return;
    }
    ++stats_.made_inline;
  }
  inner_->coarse_tile(mip, tx, ty, out);
}

size_t PrefetchingBase::ready() const {
  std::lock_guard lock(mu_);
  return ready_.size();
}

PrefetchingBase::Stats PrefetchingBase::stats() const {
  std::lock_guard lock(mu_);
  return stats_;
}

}  // namespace loam::server
