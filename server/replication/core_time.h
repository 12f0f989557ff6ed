// The time the replication core runs on. The core never reads a clock: the transport reads
// one and passes the time in on every call (tests pass a made-up one).
#pragma once

#include <chrono>

namespace loam::server {

using CoreClock = std::chrono::steady_clock;
using CoreTime = CoreClock::time_point;
using CoreDuration = CoreClock::duration;

}  // namespace loam::server
