// Admission, part of ReplicationCore: the handshake pools, Hello (version, access token,
// role, the session cap, the resume key), the per-client request bucket, and a Deform's way in
// (role, resend, storage, rate, pending cap, validity, cost) before it waits for its tick.
#include <algorithm>

#include "protocol/stamps/stamp_apply.h"
#include "server/replication/core_detail.h"
#include "server/replication/replication_core.h"

namespace loam::server {

using namespace core_detail;

namespace {

bool editor_role(wire::Role r) { return r != wire::Role::kSpectator; }

// "1.2.3.4:5678" or "::1:5678": the address, without the port.
std::string address_of(const std::string& peer) {
  const size_t colon = peer.rfind(':');
  return colon == std::string::npos ? peer : peer.substr(0, colon);
}

}  // namespace

ClientId ReplicationCore::connect(const std::string& peer, CoreTime now) {
  Client& c = clients_[next_id_];
  c.id = next_id_++;
  c.peer = peer;
  c.address = address_of(peer);
  ++handshakes_;
  const uint32_t from_address = ++handshakes_by_address_[c.address];
  c.deforms = TokenBucket(config_.deforms_per_second, config_.deform_burst, config_.deform_burst, now);
  const double cost_capacity = double(std::max(config_.stamp_cost_per_second, config_.max_stamp_cost));
  c.stamp_cost = TokenBucket(double(config_.stamp_cost_per_second), cost_capacity, cost_capacity, now);
  c.requests = TokenBucket(config_.requests_per_second, config_.request_burst, config_.request_burst, now);
  // Credit accrues at the budget, up to one second's worth (a short burst after idling).
  const double budget = double(config_.client_bytes_per_second);
  c.credit = TokenBucket(budget, budget, 0.0, now);
  ++stats_.connects;
  note("connect", {{"client", std::to_string(c.id)}, {"peer", peer}});
  // Connections that have not said Hello have a pool of their own, smaller per address, so
  // that nobody can hold the session slots (--max-clients) without a token.
  if (handshakes_ > config_.max_handshakes || from_address > config_.max_handshakes_per_address) {
    const ClientId id = c.id;
    fatal(c, wire::WireErrorCode::kServerFull, "",
          handshakes_ > config_.max_handshakes
              ? "too many connections in their handshake (" + std::to_string(config_.max_handshakes) + ")"
              : "too many connections in their handshake from " + c.address + " (" +
                    std::to_string(config_.max_handshakes_per_address) + ")",
          wire::ByeReason::kKicked);
    return id;
  }
  return c.id;
}

void ReplicationCore::stream_error(ClientId id, const Error& e) {
  const auto it = clients_.find(id);
  if (it == clients_.end()) return;
  // The stream cannot be trusted to be in sync any more: Error, Bye, close. A Hello of another
  // major version is refused by its decoder (the rest of its layout may differ): the peer is
  // told version_mismatch, which it can act on (upgrade), not protocol_error.
  const bool version = it->second.state == Client::State::kHandshake && e.code == ErrorCode::kUnsupported &&
                       e.field == "hello.version_major";
  fatal(it->second, wire::to_wire(e.code), e.field, e.describe(),
        version ? wire::ByeReason::kVersionMismatch : wire::ByeReason::kProtocolError);
}

void ReplicationCore::timed_out(ClientId id, bool in_handshake) {
  const auto it = clients_.find(id);
  if (it == clients_.end()) return;
  if (in_handshake != (it->second.state == Client::State::kHandshake)) return;  // a stale timer
  if (in_handshake) {
    fatal(it->second, wire::WireErrorCode::kInvalidArgument, "hello", "no Hello within the handshake timeout",
          wire::ByeReason::kTimeout);
  } else {
    fatal(it->second, wire::WireErrorCode::kInvalidArgument, "", "idle timeout", wire::ByeReason::kTimeout);
  }
}

std::optional<CoreTime> ReplicationCore::reads_paused_until(ClientId id, CoreTime now) const {
  const auto it = clients_.find(id);
  if (it == clients_.end() || !it->second.requests_refused) return std::nullopt;
  return it->second.requests.holds_at(1.0, now);
}

bool ReplicationCore::admit_request(Client& c, wire::MessageType type, CoreTime now) {
  switch (type) {
    case wire::MessageType::kPing:
    case wire::MessageType::kSubscribe:
    case wire::MessageType::kUnsubscribe:
    case wire::MessageType::kStampImageRequest:
    case wire::MessageType::kStampImageListRequest:
    case wire::MessageType::kStatsRequest: break;
    default: return true;  // Hello, Bye, Deform (its own bucket), and what the switch refuses
  }
  c.requests.refill(now);
  if (c.requests.take(1.0)) {
    c.requests_refused = false;
    return true;
  }
  // One Error per run of refusals: a flood must not be answered with a flood.
  ++stats_.requests_refused;
  if (!c.requests_refused) {
    c.requests_refused = true;
    violation(c, wire::WireErrorCode::kRateLimited, "requests.rate",
              std::string(wire::to_string(type)) + " refused: over " +
                  std::to_string(int(config_.requests_per_second)) + " requests a second");
  }
  return false;
}

void ReplicationCore::on_hello(Client& c, const wire::Hello& h) {
  // From a socket, another major version never gets here: the Hello's decoder refuses it
  // (stream_error). A caller handing the core a decoded Hello is answered the same way.
  if (h.version_major != wire::kProtocolMajor) {
    note("reject", {{"client", std::to_string(c.id)},
                    {"reason", "version"},
                    {"peer_major", std::to_string(h.version_major)}});
    ++stats_.violations;
    send(c, wire::version_mismatch(h.version_major, h.version_minor));
    send(c, wire::Bye{wire::ByeReason::kVersionMismatch, "protocol major version mismatch"});
    close(c.id, "version mismatch");
    return;
  }
  wire::Role granted = h.requested_role;
  switch (check_access(access_, h.access_token)) {
    case Access::kAsRequested: break;
    case Access::kSpectator: granted = wire::Role::kSpectator; break;
    case Access::kDenied:
      fatal(c, wire::WireErrorCode::kUnauthorized, "hello.access_token",
            h.access_token ? "wrong access token" : "this server requires an access token",
            wire::ByeReason::kKicked);
      return;
  }
  if (sessions_ >= config_.max_clients) {
    fatal(c, wire::WireErrorCode::kServerFull, "",
          "server full (" + std::to_string(config_.max_clients) + " clients)", wire::ByeReason::kKicked);
    return;
  }
  c.role = granted;
  c.editor = editor_role(granted);
  c.name = h.client_name;
  // Out of the handshake pool, into a session slot.
  --handshakes_;
  if (const auto a = handshakes_by_address_.find(c.address);
      a != handshakes_by_address_.end() && --a->second == 0)
    handshakes_by_address_.erase(a);
  ++sessions_;
  c.state = Client::State::kReady;
  // The newest connection of a resume key gets the answers of the Deforms still waiting.
  c.resume_key = h.resume_key;
  if (c.resume_key != 0) key_owner_[c.resume_key] = c.id;
  wire::Welcome w;
  w.client_id = c.id;
  w.granted_role = granted;
  w.world = terrain_.world().params();
  // What its events continue from: the last stamp applied and fanned out.
  w.global_sequence = published_seq_;
  w.tick_rate_hz = uint16_t(config_.tick_hz);
  w.limits.max_frame_bytes = config_.max_frame_bytes;
  w.limits.max_subscribed_tiles = config_.max_subscriptions;
  w.limits.max_pending_deforms = config_.max_pending_deforms;
  w.limits.max_deforms_per_second = uint32_t(config_.deforms_per_second);
  // After a restart the ledger is empty: the client must not resend what it never saw
  // answered, since the log may hold it already.
  w.resume_key_known = h.resume_key != 0 && ledger_.knows(h.resume_key);
  // Version 0 of every tile is the base's tile when nothing was written at version 0 (a DEM's
  // samples are edits at version 0 over a fill: those must travel).
  w.base_identity = terrain_.world().initial_is_base() ? terrain_.world().base().identity() : 0;
  send(c, w);
  note("hello", {{"client", std::to_string(c.id)}, {"name", c.name}, {"role", wire::to_string(granted)}});
}

void ReplicationCore::prefetch_reach(const QuantizedStamp& q) {
  if (!prefetch_ || q.layer != Layer::kCoarse) return;
  auto reach = stamp_reach(q, terrain_.world().params(), &terrain_.textures(), terrain_.limits());
  if (!reach || reach->empty()) return;
  // Every mip's tiles under the reach: the stamp writes mip 0, commit() updates the mips above.
  const World& w = terrain_.world();
  const WorldParams& p = w.params();
  std::vector<TileCoord> ahead;
  const RectI r0 = reach->intersect(p.sample_rect());
  for (int32_t m = 0; m < p.mip_count(); ++m) {
    const RectI samples = m == 0 ? r0 : mip_samples_reaching(p, m, r0);
    const RectI t = tiles_overlapping(samples).intersect(p.tile_range(m));
    if (t.area() > 64) return;  // a stamp this wide costs more than a prefetch saves
    for (int64_t ty = t.y0; ty < t.y1; ++ty)
      for (int64_t tx = t.x0; tx < t.x1; ++tx)
        if (w.needs_base_read(m, int32_t(tx), int32_t(ty)))
          ahead.push_back({Layer::kCoarse, uint8_t(m), int32_t(tx), int32_t(ty)});
  }
  prefetch_->prefetch(ahead);
}

void ReplicationCore::on_deform(Client& c, const wire::Deform& d, CoreTime now) {
  auto reject = [&](wire::WireErrorCode code, const std::string& field, const std::string& why) {
    ++stats_.deforms_rejected;
    ++stats_.deforms_rejected_by[wire::to_string(code)];
    ++stats_.violations;
    ++c.violations;
    wire::DeformAck ack;
    ack.client_seq = d.client_seq;
    ack.accepted = false;
    ack.reject_code = code;
    ack.field = field.substr(0, wire::kMaxFieldNameBytes);
    if (c.resume_key != 0) ledger_.answered(c.resume_key, ack);
    send(c, ack);
    note("deform_rejected", {{"client", std::to_string(c.id)},
                             {"client_seq", std::to_string(d.client_seq)},
                             {"code", wire::to_string(code)},
                             {"field", field},
                             {"why", why}});
  };
  if (!c.editor) {
    reject(wire::WireErrorCode::kUnauthorized, "role", "viewers cannot deform");
    return;
  }
  // Sent again after a reconnect: answered as the first time, never applied twice.
  if (c.resume_key != 0) {
    const DeformLedger::Lookup seen = ledger_.lookup(c.resume_key, d.client_seq);
    if (seen.seen != DeformLedger::Seen::kNew) {
      ++stats_.deforms_resent;
      if (seen.seen == DeformLedger::Seen::kAnswered) send(c, seen.ack);
      return;  // kPending: answered on this connection when its tick commits it
    }
  }
  if (!storage_.writable()) {
    // Not the client's fault: refused, not counted as a violation.
    wire::DeformAck ack;
    ack.client_seq = d.client_seq;
    ack.accepted = false;
    ack.reject_code = wire::WireErrorCode::kIo;
    ack.field = "storage.unavailable";
    ++stats_.deforms_rejected;
    ++stats_.deforms_rejected_by[wire::to_string(ack.reject_code)];
    if (c.resume_key != 0) ledger_.answered(c.resume_key, ack);
    send(c, ack);
    return;
  }
  c.deforms.refill(now);
  c.stamp_cost.refill(now);
  if (!c.deforms.holds(1.0)) {
    reject(wire::WireErrorCode::kRateLimited, "deform", "rate limit exceeded");
    return;
  }
  if (c.unacked >= config_.max_pending_deforms) {
    reject(wire::WireErrorCode::kTooManyPending, "deform",
           "too many unacknowledged deforms (" + std::to_string(config_.max_pending_deforms) + ")");
    return;
  }
  if (const Status st = terrain_.check(d.stamp); !st.ok()) {
    reject(wire::to_wire(st.error().code), st.error().field, st.error().describe());
    return;
  }
  // Admission by cost: one stamp may be worth a million small ones.
  const auto cost = stamp_cost(d.stamp, terrain_.world().params(), &terrain_.textures(), terrain_.limits());
  if (!cost) {
    reject(wire::to_wire(cost.error().code), cost.error().field, cost.error().describe());
    return;
  }
  if (*cost > config_.max_stamp_cost) {
    reject(wire::WireErrorCode::kOversize, "stamp.cost",
           "the stamp costs " + std::to_string(*cost) + " sample updates, over the limit of " +
               std::to_string(config_.max_stamp_cost) + " per stamp");
    return;
  }
  if (!c.stamp_cost.holds(double(*cost))) {
    reject(wire::WireErrorCode::kRateLimited, "stamp.cost",
           "the stamp costs " + std::to_string(*cost) +
               " sample updates, over what is left of this client's " +
               std::to_string(config_.stamp_cost_per_second) + " a second");
    return;
  }
  c.stamp_cost.spend(double(*cost));
  c.deforms.spend(1.0);
  ++c.unacked;
  pending_.push_back({c.id, d.client_seq, d.stamp, *cost, c.resume_key});
  if (!applier_->busy()) prefetch_reach(d.stamp);  // it reads the world's tile table
  if (c.resume_key != 0) ledger_.admitted(c.resume_key, d.client_seq);
}

}  // namespace loam::server
