#include "client/net/deform_pacer.h"

#include <algorithm>

namespace loam::client {

void DeformPacer::set_limits(uint32_t max_unacked, double per_second, Clock::time_point now) {
  max_unacked_ = max_unacked;
  per_second_ = per_second;
  next_send_ = now;
}

void DeformPacer::submit(uint32_t client_seq, const QuantizedStamp& stamp) {
  queued_.emplace_back(client_seq, stamp);
}

void DeformPacer::acknowledged(uint32_t client_seq) { unacked_.erase(client_seq); }

std::vector<std::pair<uint32_t, QuantizedStamp>> DeformPacer::take_sendable(Clock::time_point now) {
  std::vector<std::pair<uint32_t, QuantizedStamp>> out;
  const auto interval =
      per_second_ > 0
          ? std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / per_second_))
          : Clock::duration::zero();
  while (!queued_.empty()) {
    if (max_unacked_ > 0 && unacked_.size() >= max_unacked_) break;
    if (per_second_ > 0 && now < next_send_) break;
    // On schedule (late by less than one interval: the caller's polling) the next send keeps
    // to it; after idling it starts from now. Over any window of w seconds no more than
    // per_second * w + 2 leave, which a server bucket of capacity >= 2 accepts (default 120).
    if (per_second_ > 0) next_send_ = (now - next_send_ >= interval ? now : next_send_) + interval;
    unacked_.emplace(queued_.front().first, queued_.front().second);
    out.push_back(std::move(queued_.front()));
    queued_.pop_front();
  }
  return out;
}

std::optional<DeformPacer::Clock::time_point> DeformPacer::next_send_time() const {
  if (queued_.empty() || (max_unacked_ > 0 && unacked_.size() >= max_unacked_)) return std::nullopt;
  return next_send_;
}

std::vector<uint32_t> DeformPacer::drop_unacked() {
  std::vector<uint32_t> out;
  for (const auto& [seq, stamp] : unacked_) out.push_back(seq);
  unacked_.clear();
  return out;
}

size_t DeformPacer::requeue_unacked() {
  const size_t n = unacked_.size();
  for (auto it = unacked_.rbegin(); it != unacked_.rend(); ++it) queued_.emplace_front(it->first, it->second);
  unacked_.clear();
  return n;
}

}  // namespace loam::client
