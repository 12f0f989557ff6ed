#include "server/replication/admission.h"

#include <algorithm>

namespace loam::server {

std::string address_of(const std::string& peer) {
  const size_t colon = peer.rfind(':');
  return colon == std::string::npos ? peer : peer.substr(0, colon);
}

Admission::Admission(const ServerConfig& c, AccessTokens access)
    : limits_{c.deforms_per_second,  c.deform_burst,
              c.requests_per_second, c.request_burst,
              c.max_stamp_cost,      c.stamp_cost_per_second,
              c.max_pending_deforms, c.max_clients,
              c.max_handshakes,      c.max_handshakes_per_address},
      access_(std::move(access)) {}

Admission::Connection Admission::connect(const std::string& address, CoreTime now) {
  Connection c;
  const Limits& l = limits_;
  c.allowance.deforms = TokenBucket(l.deforms_per_second, l.deform_burst, l.deform_burst, now);
  const double cost_capacity = double(std::max(l.stamp_cost_per_second, l.max_stamp_cost));
  c.allowance.stamp_cost = TokenBucket(double(l.stamp_cost_per_second), cost_capacity, cost_capacity, now);
  c.allowance.requests = TokenBucket(l.requests_per_second, l.request_burst, l.request_burst, now);
  ++handshakes_;
  const size_t from_address = ++by_address_[address];
  // Connections that have not said Hello have a pool of their own, smaller per address, so
  // that nobody can hold the session slots (--max-clients) without a token.
  if (handshakes_ > l.max_handshakes) {
    c.refused = Refusal{wire::WireErrorCode::kServerFull, "",
                        "too many connections in their handshake (" + std::to_string(l.max_handshakes) + ")"};
  } else if (from_address > l.max_handshakes_per_address) {
    c.refused = Refusal{wire::WireErrorCode::kServerFull, "",
                        "too many connections in their handshake from " + address + " (" +
                            std::to_string(l.max_handshakes_per_address) + ")"};
  }
  return c;
}

std::variant<wire::Role, Refusal> Admission::enter_session(const std::string& address,
                                                           const std::optional<wire::AccessToken>& token,
                                                           wire::Role requested) {
  wire::Role granted = requested;
  switch (check_access(access_, token)) {
    case Access::kAsRequested: break;
    case Access::kSpectator: granted = wire::Role::kSpectator; break;
    case Access::kDenied:
      return Refusal{wire::WireErrorCode::kUnauthorized, "hello.access_token",
                     token ? "wrong access token" : "this server requires an access token"};
  }
  if (sessions_ >= limits_.max_clients)
    return Refusal{wire::WireErrorCode::kServerFull, "",
                   "server full (" + std::to_string(limits_.max_clients) + " clients)"};
  leave_handshake(address);
  ++sessions_;
  return granted;
}

void Admission::leave_handshake(const std::string& address) {
  --handshakes_;
  if (const auto a = by_address_.find(address); a != by_address_.end() && --a->second == 0)
    by_address_.erase(a);
}

void Admission::leave(const std::string& address, bool in_session) {
  if (in_session)
    --sessions_;
  else
    leave_handshake(address);
}

Admission::RequestVerdict Admission::admit_request(ClientAllowance& a, wire::MessageType type,
                                                   CoreTime now) const {
  switch (type) {
    case wire::MessageType::kPing:
    case wire::MessageType::kSubscribe:
    case wire::MessageType::kUnsubscribe:
    case wire::MessageType::kStampImageRequest:
    case wire::MessageType::kStampImageListRequest:
    case wire::MessageType::kStatsRequest: break;
    default: return {};  // Hello, Bye, Deform (its own bucket), and what the core refuses anyway
  }
  a.requests.refill(now);
  if (a.requests.take(1.0)) {
    a.requests_refused = false;
    return {};
  }
  // One answer per run of refusals: a flood must not be answered with a flood.
  RequestVerdict v{false, std::nullopt};
  if (!a.requests_refused) {
    a.requests_refused = true;
    v.answer = Refusal{wire::WireErrorCode::kRateLimited, "requests.rate",
                       std::string(wire::to_string(type)) + " refused: over " +
                           std::to_string(int(limits_.requests_per_second)) + " requests a second"};
  }
  return v;
}

std::optional<CoreTime> Admission::reads_paused_until(const ClientAllowance& a, CoreTime now) const {
  if (!a.requests_refused) return std::nullopt;
  return a.requests.holds_at(1.0, now);
}

std::optional<Refusal> Admission::check_deform(ClientAllowance& a, CoreTime now) const {
  a.deforms.refill(now);
  a.stamp_cost.refill(now);
  if (!a.deforms.holds(1.0))
    return Refusal{wire::WireErrorCode::kRateLimited, "deform", "rate limit exceeded"};
  if (a.unacked >= limits_.max_pending_deforms)
    return Refusal{wire::WireErrorCode::kTooManyPending, "deform",
                   "too many unacknowledged deforms (" + std::to_string(limits_.max_pending_deforms) + ")"};
  return std::nullopt;
}

std::optional<Refusal> Admission::check_cost(const ClientAllowance& a, uint64_t cost) const {
  // Admission by cost: one stamp may be worth a million small ones.
  if (cost > limits_.max_stamp_cost)
    return Refusal{wire::WireErrorCode::kOversize, "stamp.cost",
                   "the stamp costs " + std::to_string(cost) + " sample updates, over the limit of " +
                       std::to_string(limits_.max_stamp_cost) + " per stamp"};
  if (!a.stamp_cost.holds(double(cost)))
    return Refusal{wire::WireErrorCode::kRateLimited, "stamp.cost",
                   "the stamp costs " + std::to_string(cost) +
                       " sample updates, over what is left of this client's " +
                       std::to_string(limits_.stamp_cost_per_second) + " a second"};
  return std::nullopt;
}

void Admission::admit(ClientAllowance& a, uint64_t cost) {
  a.stamp_cost.spend(double(cost));
  a.deforms.spend(1.0);
  ++a.unacked;
}

}  // namespace loam::server
