// The Stats of a live loam-server, asked on a connection of its own (as `loam-client probe`
// does): for suites that report the server's own counters next to what clients measured.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>

#include "client/net/connection.h"

namespace loam::bench {

inline std::optional<wire::Stats> server_stats(uint16_t port) {
  using namespace std::chrono_literals;
  client::Connection c;
  wire::Hello h;
  h.client_name = "bench-stats";
  h.requested_role = wire::Role::kSpectator;
  if (!c.connect("127.0.0.1", port, h)) return std::nullopt;
  if (!c.send(wire::StatsRequest{7}).ok()) return std::nullopt;
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (std::chrono::steady_clock::now() < deadline) {
    auto m = c.next(100ms);
    if (!m) return std::nullopt;
    if (*m)
      if (auto* st = std::get_if<wire::Stats>(&**m); st && st->request_id == 7) return *st;
  }
  return std::nullopt;
}

}  // namespace loam::bench
