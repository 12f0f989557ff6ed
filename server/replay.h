// Replay: rebuild a world from a deformation log's initial terrain and records, exactly as
// the server applied them: each segment under the stamp limits it recorded, with the
// texture-stamp images the session stored. A record that fails to apply is an error naming it.
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
  std::string tail_damage;  // a damaged tail that was ignored (only with allow_damaged)
};

// `segments` in order (segment 0 first, or, where retention removed the first segments, the
// first one kept: the replay then starts from the snapshot it continues, which must be in
// `data_dir`); `data_dir` is where snapshot-based initial terrains are found (the folder
// holding snapshots/). Stops after `until_seq`. `backend` evaluates the
// stamps (the GPU must give the CPU reference's integers, so the hash is the same).
// `stamp_images` are texture-stamp image files to register besides those stored under
// <data_dir>/images. A damaged segment (its records end before the file does) is an Error
// unless `allow_damaged`: then the records before the damage replay and tail_damage says why.
Result<ReplayResult> replay_log(const std::vector<std::string>& segments, const std::string& data_dir,
                                uint64_t until_seq = std::numeric_limits<uint64_t>::max(),
                                gpu::BackendKind backend = gpu::BackendKind::kCpu,
                                const std::vector<std::string>& stamp_images = {},
                                bool allow_damaged = false);

}  // namespace loam::server
