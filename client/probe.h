// `loam-client probe`: the health check of a running session, for supervisors (Docker's
// HEALTHCHECK, Kubernetes' probes, monitoring). It joins as a spectator — a real handshake,
// so a server that accepts TCP but cannot serve fails it — asks for Stats, prints one line
// (or JSON) and leaves. No GL, no subscriptions: cheap enough to run every few seconds.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

#include "protocol/wire/messages.h"
#include "transport/tls_context.h"

namespace loam::client {

struct ProbeOptions {
  std::string host = "127.0.0.1";
  uint16_t port = 7878;
  std::optional<wire::AccessToken> token;  // needed where the server has tokens
  transport::TlsClientOptions tls;
  std::chrono::milliseconds timeout{5000};  // connect + handshake + Stats
  bool json = false;
};

// Returns the process exit code: 0 healthy, 1 unreachable, refused or silent.
int run_probe(const ProbeOptions& options);

}  // namespace loam::client
