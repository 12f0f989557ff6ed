// The time the replication core runs on. The core never reads a clock: the transport reads
// one and passes the time in on every call (yojimbo's AdvanceTime; tests pass a made-up one).
// CoreClock has the steady clock's resolution and no function that tells the time, so a clock
// read cannot creep in here (the transport converts its own clock's readings).
#pragma once

#include <chrono>
#include <cstdint>

namespace loam::server {

struct CoreClock {
  using duration = std::chrono::nanoseconds;
  using rep = duration::rep;
  using period = duration::period;
  using time_point = std::chrono::time_point<CoreClock>;
  static constexpr bool is_steady = true;
};
using CoreTime = CoreClock::time_point;
using CoreDuration = CoreClock::duration;

// Wall-clock time, microseconds since the Unix epoch: what Pong reports for the client's clock
// offset and what a new log segment records as its creation. Given like CoreTime.
using UnixMicros = uint64_t;

}  // namespace loam::server
