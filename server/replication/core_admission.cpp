// Admission, part of ReplicationCore: connections, Hello and Deforms through Admission
// (admission.h) and the ledger (commit_pipeline.h), their refusals turned into frames. A
// Deform's way in: role, resend, storage, rate, pending cap, validity, cost; then it waits for
// its tick.
#include <algorithm>

#include "protocol/stamps/stamp_apply.h"
#include "server/replication/core_detail.h"
#include "server/replication/replication_core.h"

namespace loam::server {

using namespace core_detail;

namespace {

bool editor_role(wire::Role r) { return r != wire::Role::kSpectator; }

}  // namespace

ClientId ReplicationCore::connect(const std::string& peer, CoreTime now) {
  Client& c = clients_[next_id_];
  c.id = next_id_++;
  c.peer = peer;
  c.address = address_of(peer);
  Admission::Connection admitted = admission_.connect(c.address, now);
  c.allowance = admitted.allowance;
  c.credit = streamer_.credit(now);
  ++stats_.connects;
  note("connect", {{"client", std::to_string(c.id)}, {"peer", peer}});
  const ClientId id = c.id;
  if (admitted.refused) {
    const Refusal& r = *admitted.refused;
    fatal(c, r.code, r.field, r.text, wire::ByeReason::kKicked);
  }
  return id;
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
  if (it == clients_.end()) return std::nullopt;
  return admission_.reads_paused_until(it->second.allowance, now);
}

bool ReplicationCore::admit_request(Client& c, wire::MessageType type, CoreTime now) {
  const Admission::RequestVerdict v = admission_.admit_request(c.allowance, type, now);
  if (v.admitted) return true;
  ++stats_.requests_refused;
  if (v.answer) violation(c, v.answer->code, v.answer->field, v.answer->text);
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
  const auto session = admission_.enter_session(c.address, h.access_token, h.requested_role);
  if (const Refusal* r = std::get_if<Refusal>(&session)) {
    fatal(c, r->code, r->field, r->text, wire::ByeReason::kKicked);
    return;
  }
  const wire::Role granted = std::get<wire::Role>(session);
  c.role = granted;
  c.editor = editor_role(granted);
  c.name = h.client_name;
  c.state = Client::State::kReady;
  // The newest connection of a resume key gets the answers of the Deforms still waiting.
  c.resume_key = h.resume_key;
  commits_.claim_key(c.resume_key, c.id);
  wire::Welcome w;
  w.client_id = c.id;
  w.granted_role = granted;
  w.world = terrain_.world().params();
  // What its events continue from: the last stamp applied and fanned out.
  w.global_sequence = commits_.published_seq();
  w.tick_rate_hz = uint16_t(config_.tick_hz);
  w.limits.max_frame_bytes = config_.max_frame_bytes;
  w.limits.max_subscribed_tiles = config_.max_subscriptions;
  w.limits.max_pending_deforms = config_.max_pending_deforms;
  w.limits.max_deforms_per_second = uint32_t(config_.deforms_per_second);
  // After a restart the ledger is empty: the client must not resend what it never saw
  // answered, since the log may hold it already.
  w.resume_key_known = h.resume_key != 0 && commits_.ledger().knows(h.resume_key);
  // Version 0 of every tile is the base's tile when nothing was written at version 0 (a DEM's
  // samples are edits at version 0 over a fill: those must travel).
  w.base_identity = terrain_.world().initial_is_base() ? terrain_.world().base().identity() : 0;
  send(c, w);
  note("hello", {{"client", std::to_string(c.id)}, {"name", c.name}, {"role", wire::to_string(granted)}});
}

void ReplicationCore::prefetch_reach(const QuantizedStamp& q) {
  if (!prefetch_ || !layer_info(q.layer).has_base) return;  // only a base's tiles are made
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

void ReplicationCore::refuse_deform(Client& c, uint32_t client_seq, const Refusal& r) {
  ++stats_.deforms_rejected;
  ++stats_.deforms_rejected_by[wire::to_string(r.code)];
  ++stats_.violations;
  ++c.violations;
  wire::DeformAck ack;
  ack.client_seq = client_seq;
  ack.accepted = false;
  ack.reject_code = r.code;
  ack.field = r.field.substr(0, wire::kMaxFieldNameBytes);
  if (c.resume_key != 0) commits_.ledger().answered(c.resume_key, ack);
  send(c, ack);
  note("deform_rejected", {{"client", std::to_string(c.id)},
                           {"client_seq", std::to_string(client_seq)},
                           {"code", wire::to_string(r.code)},
                           {"field", r.field},
                           {"why", r.text}});
}

void ReplicationCore::on_deform(Client& c, const wire::Deform& d, CoreTime now) {
  const auto reject = [&](wire::WireErrorCode code, const std::string& field, const std::string& why) {
    refuse_deform(c, d.client_seq, {code, field, why});
  };
  if (!c.editor) {
    reject(wire::WireErrorCode::kUnauthorized, "role", "viewers cannot deform");
    return;
  }
  // Sent again after a reconnect: answered as the first time, never applied twice.
  if (c.resume_key != 0) {
    const DeformLedger::Lookup seen = commits_.ledger().lookup(c.resume_key, d.client_seq);
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
    if (c.resume_key != 0) commits_.ledger().answered(c.resume_key, ack);
    send(c, ack);
    return;
  }
  if (const auto refused = admission_.check_deform(c.allowance, now)) {
    refuse_deform(c, d.client_seq, *refused);
    return;
  }
  if (const Status st = terrain_.check(d.stamp); !st.ok()) {
    reject(wire::to_wire(st.error().code), st.error().field, st.error().describe());
    return;
  }
  const auto cost = stamp_cost(d.stamp, terrain_.world().params(), &terrain_.textures(), terrain_.limits());
  if (!cost) {
    reject(wire::to_wire(cost.error().code), cost.error().field, cost.error().describe());
    return;
  }
  if (const auto refused = admission_.check_cost(c.allowance, *cost)) {
    refuse_deform(c, d.client_seq, *refused);
    return;
  }
  Admission::admit(c.allowance, *cost);
  commits_.queue({c.id, d.client_seq, d.stamp, *cost, c.resume_key});
  if (!commits_.busy()) prefetch_reach(d.stamp);  // it reads the world's tile table
}

}  // namespace loam::server
