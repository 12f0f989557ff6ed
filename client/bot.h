// `loam-client bot`: a headless client (no GL) that joins a session, subscribes to the whole
// world, deforms it with seeded random stamps at a steady rate, checks its confirmed store
// against the server's TileHashes and reports. The main job runs two; tests and load runs more.
// With a roaming speed it walks a loop across the world instead, subscribing as a viewer
// does (client/render/clipmap_interest.h: mips by distance, with its focus) and stamping
// near itself: the load that streaming is measured under.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "protocol/wire/messages.h"

namespace loam::client {

struct BotOptions {
  std::string host = "127.0.0.1";
  uint16_t port = 7878;
  std::string name = "bot";
  std::optional<wire::AccessToken> token;  // needed where the server has tokens
  uint32_t stamps = 100;
  double rate = 10.0;  // stamps per second
  uint32_t seed = 1;
  double roam_mps = 0;  // > 0: walk a loop across the world at this speed (meters per second)
};

// Returns the process exit code: 0, 1 when it could not join, 3 after a hash mismatch.
int run_bot(const BotOptions& options);

}  // namespace loam::client
