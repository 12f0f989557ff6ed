// Admission: who may connect, who gets a session and in which role, and how much each client
// may ask. It holds the handshake pools (all connections, and per address) and the session
// slots, the access tokens, and each client's allowance: token buckets for its Deforms, its
// stamps' cost and its other requests, and its count of Deforms waiting for an ack. Pure: the
// time is given, and a refusal is a value the core turns into frames.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <variant>

#include "protocol/wire/messages.h"
#include "server/access_tokens.h"
#include "server/replication/core_time.h"
#include "server/replication/token_bucket.h"
#include "server/server_config.h"

namespace loam::server {

// Why something was refused, as the client is told it.
struct Refusal {
  wire::WireErrorCode code = wire::WireErrorCode::kInvalidArgument;
  std::string field;
  std::string text;
};

// What one client may still ask for.
struct ClientAllowance {
  TokenBucket deforms;            // Deforms
  TokenBucket stamp_cost;         // the sample updates of its stamps
  TokenBucket requests;           // Subscribe, Unsubscribe, Ping, ...
  uint32_t unacked = 0;           // Deforms admitted, not yet acknowledged
  bool requests_refused = false;  // refused since the last one admitted: it has been told
};

class Admission {
 public:
  Admission(const ServerConfig& config, AccessTokens access);

  // A new connection from `address` (the peer without its port) joins the handshake pools.
  // Its allowance, full; and the refusal when a pool is over its bound (it stays counted
  // until leave()).
  struct Connection {
    ClientAllowance allowance;
    std::optional<Refusal> refused;
  };
  Connection connect(const std::string& address, CoreTime now);
  // A Hello: the role its token grants (`requested`, or spectator), and a session slot in
  // place of its handshake slot. Refused (a wrong token, the server full): it keeps its
  // handshake slot.
  std::variant<wire::Role, Refusal> enter_session(const std::string& address,
                                                  const std::optional<wire::AccessToken>& token,
                                                  wire::Role requested);
  // The connection is gone: its slot is free.
  void leave(const std::string& address, bool in_session);

  // A request other than Hello, Bye and Deform takes a token from the request bucket. A
  // refusal is answered once per run of refusals (`answer` set on the first only).
  struct RequestVerdict {
    bool admitted = true;
    std::optional<Refusal> answer;
  };
  RequestVerdict admit_request(ClientAllowance& a, wire::MessageType type, CoreTime now) const;
  // When a client refused for its request rate may be read again; nullopt: now.
  std::optional<CoreTime> reads_paused_until(const ClientAllowance& a, CoreTime now) const;

  // A Deform, before its stamp is looked at: its rate, and the cap on unacknowledged ones.
  std::optional<Refusal> check_deform(ClientAllowance& a, CoreTime now) const;
  // Its stamp's cost (sample updates): the cap per stamp, and what is left of the client's.
  std::optional<Refusal> check_cost(const ClientAllowance& a, uint64_t cost) const;
  // Admitted: a Deform and its cost spent, one more waiting for its ack.
  static void admit(ClientAllowance& a, uint64_t cost);
  static void acknowledged(ClientAllowance& a) {
    if (a.unacked > 0) --a.unacked;
  }

  const AccessTokens& access() const { return access_; }
  void set_access(AccessTokens access) { access_ = std::move(access); }
  size_t handshakes() const { return handshakes_; }
  size_t sessions() const { return sessions_; }
  size_t handshakes_from(const std::string& address) const {
    const auto it = by_address_.find(address);
    return it == by_address_.end() ? 0 : it->second;
  }

 private:
  void leave_handshake(const std::string& address);

  struct Limits {  // the config's, in its types (the refusals quote them)
    double deforms_per_second, deform_burst, requests_per_second, request_burst;
    uint64_t max_stamp_cost, stamp_cost_per_second;
    uint32_t max_pending_deforms, max_clients, max_handshakes, max_handshakes_per_address;
  } limits_;
  AccessTokens access_;
  size_t handshakes_ = 0, sessions_ = 0;
  std::map<std::string, size_t> by_address_;
};

// "1.2.3.4:5678" or "::1:5678": the address, without the port.
std::string address_of(const std::string& peer);

}  // namespace loam::server
