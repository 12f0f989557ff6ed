// A token bucket: a level that refills at `rate` per second up to `capacity`, refilled from the
// time given on each call (the replication core never reads a clock). The core's four limits
// are each one: a client's deforms, its stamp cost (sample updates), its other requests, and
// its bulk byte credit (which may be spent below zero: a region is sent whole, and the debt
// is paid back before the next one).
#pragma once

#include <algorithm>
#include <chrono>
#include <optional>

#include "server/replication/core_time.h"

namespace loam::server {

class TokenBucket {
 public:
  TokenBucket() = default;
  // Full at `level` (usually the capacity) at time `now`.
  TokenBucket(double rate, double capacity, double level, CoreTime now)
      : rate_(rate), capacity_(capacity), level_(level), refilled_(now) {}

  // What has accrued since the last refill, up to the capacity; the refill time moves to `now`.
  void refill(CoreTime now) {
    level_ = level_at(now);
    refilled_ = now;
  }
  // The level a refill at `now` would give, without refilling.
  double level_at(CoreTime now) const {
    return std::min(capacity_, level_ + std::chrono::duration<double>(now - refilled_).count() * rate_);
  }
  double level() const { return level_; }
  bool holds(double n) const { return level_ >= n; }
  // Takes `n` when the bucket holds it; false (and nothing taken) when it does not.
  bool take(double n) {
    if (!holds(n)) return false;
    level_ -= n;
    return true;
  }
  // Takes `n` whatever the level: it may go below zero (a debt refills first).
  void spend(double n) { level_ -= n; }
  // When a bucket refilled at `now` holds `n`; nullopt when it holds it now (or never will: a
  // zero rate).
  std::optional<CoreTime> holds_at(double n, CoreTime now) const {
    const double level = level_at(now);
    if (level >= n || rate_ <= 0) return std::nullopt;
    return now + std::chrono::duration_cast<CoreDuration>(std::chrono::duration<double>((n - level) / rate_));
  }

 private:
  double rate_ = 0, capacity_ = 0, level_ = 0;
  CoreTime refilled_{};
};

}  // namespace loam::server
