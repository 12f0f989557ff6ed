// Replay: rebuild a world from a deformation log's initial terrain and records, exactly as
// the server applied them (a stamp that failed to apply is a no-op in both).
#pragma once

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "gpu/backend_choice.h"
#include "protocol/result.h"
#include "protocol/world.h"

namespace loam::server {

struct ReplayResult {
  World world;
  uint64_t last_seq = 0;
  uint64_t records = 0;
  uint64_t failed_stamps = 0;
  std::string tail_damage;  // a damaged tail that was ignored (not repaired)
};

// `segments` in order (segment 0 first); `data_dir` is where snapshot-based initial terrains
// are found (the folder holding snapshots/). Stops after `until_seq`. `backend` evaluates the
// stamps (the GPU must give the CPU reference's integers, so the hash is the same).
// `stamp_images` are the texture-stamp image files the session registered (--stamp-image).
Result<ReplayResult> replay_log(const std::vector<std::string>& segments, const std::string& data_dir,
                                uint64_t until_seq = std::numeric_limits<uint64_t>::max(),
                                gpu::BackendKind backend = gpu::BackendKind::kCpu,
                                const std::vector<std::string>& stamp_images = {});

}  // namespace loam::server
