// The client's side of the Deform limits its Welcome announces: at most max_pending_deforms
// sent and not yet acknowledged, and no faster than max_deforms_per_second. Deforms the game
// asks for beyond them wait here, in order, and leave as acks come back and time passes, so a
// backlog (a burst of clicks, the stamps made while the link was down) is accepted by the
// server instead of refused. Pure: the caller passes the time and sends what it is given.
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <optional>
#include <utility>
#include <vector>

#include "protocol/stamps/stamp.h"

namespace loam::client {

class DeformPacer {
 public:
  using Clock = std::chrono::steady_clock;

  // `max_unacked` 0 or `per_second` <= 0: that limit is off.
  void set_limits(uint32_t max_unacked, double per_second, Clock::time_point now);
  // A Deform to send, with the client's sequence number for it.
  void submit(uint32_t client_seq, const QuantizedStamp& stamp);
  // The server answered it (accepted or not): its slot is free.
  void acknowledged(uint32_t client_seq);
  // The Deforms that may leave now, oldest first; they count as unacknowledged from here.
  std::vector<std::pair<uint32_t, QuantizedStamp>> take_sendable(Clock::time_point now);
  // Sent and not acknowledged when the connection went away: their answers will not come on
  // it. They go back to the front of the queue, in order, to be sent again on the next
  // connection (the server recognises them by the resume key: answered once, applied once).
  // Returns how many.
  size_t requeue_unacked();
  // The same, when they must not go again (the server cannot tell whether it applied them):
  // they are dropped; returns their sequence numbers.
  std::vector<uint32_t> drop_unacked();

  // When the oldest queued Deform may leave, if one waits for time (not for an ack).
  std::optional<Clock::time_point> next_send_time() const;

  size_t queued() const { return queued_.size(); }
  size_t unacked() const { return unacked_.size(); }

 private:
  uint32_t max_unacked_ = 0;
  double per_second_ = 0;
  // Pacing: at most one Deform per 1 / per_second; the server's burst is not known here, so
  // none is assumed.
  Clock::time_point next_send_{};
  std::deque<std::pair<uint32_t, QuantizedStamp>> queued_;
  std::map<uint32_t, QuantizedStamp> unacked_;  // sent, by client_seq
};

}  // namespace loam::client
