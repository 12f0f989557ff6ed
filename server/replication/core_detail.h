// Helpers shared by the files of ReplicationCore (replication_core.cpp and core_*.cpp):
// frame encoding. Private to them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "protocol/wire/framing.h"
#include "server/replication/core_time.h"
#include "server/replication/region_frames.h"

namespace loam::server {
struct CoreOutput;
}  // namespace loam::server

namespace loam::server::core_detail {

// One message as a frame shared by every client it goes to; null when it cannot be encoded
// (the error goes to `out`'s log).
FramePtr encode(const wire::Message& m, CoreOutput& out);

}  // namespace loam::server::core_detail
