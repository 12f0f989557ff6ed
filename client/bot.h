// `loam-client bot`: a headless client (no GL) that joins a session, subscribes to the whole
// world, deforms it with seeded random stamps at a steady rate, checks its confirmed store
// against the server's TileHashes and reports. The main job runs two; tests and load runs more.
// With a roaming speed it walks a loop across the world instead, subscribing as a viewer
// does (client/lod/clipmap_interest.h: mips by distance, with its focus) and stamping
// near itself: the load that streaming is measured under.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "protocol/wire/messages.h"
#include "transport/tls_context.h"

namespace loam::client {

struct BotOptions {
  std::string host = "127.0.0.1";
  uint16_t port = 7878;
  std::string name = "bot";
  std::optional<wire::AccessToken> token;  // needed where the server has tokens
  transport::TlsClientOptions tls;
  uint32_t stamps = 100;
  double rate = 10.0;  // stamps per second
  uint32_t seed = 1;
  double roam_mps = 0;  // > 0: walk a loop across the world at this speed (meters per second)
};

// Bot exit codes: what a script or a load test can rely on.
inline constexpr int kBotOk = 0;          // every stamp accepted, no hash mismatch
inline constexpr int kBotCannotJoin = 1;  // could not connect, join or subscribe
inline constexpr int kBotMismatch = 3;    // the confirmed store disagreed with the server's hashes
inline constexpr int kBotLostStamps = 4;  // stamps refused, or unanswered after reconnecting failed

// Runs the bot; returns its exit code (a mismatch wins over lost stamps).
int run_bot(const BotOptions& options);

}  // namespace loam::client
