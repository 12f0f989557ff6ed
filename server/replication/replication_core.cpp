#include "server/replication/replication_core.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>

#include "protocol/hex64.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/wire/framing.h"
#include "server/event_log.h"

namespace loam::server {

namespace {

bool editor_role(wire::Role r) { return r != wire::Role::kSpectator; }

// The one percentile rule of the stats line and the Stats message (nearest rank below), so
// the two never disagree on the same ticks. `sorted` ascending; 0 when empty.
double percentile(const std::vector<double>& sorted, double p) {
  return sorted.empty() ? 0.0 : sorted[size_t(p * double(sorted.size() - 1))];
}

// Untouched tiles a hashes round may generate (or read from a pack) to hash them: about 4 ms
// of refinement. A roaming client's new tiles would otherwise all be made in one tick.
constexpr uint32_t kHashBaseReadsPerRound = 16;

std::string fmt_ms(double ms) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", ms);
  return buf;
}

double seconds(CoreClock::duration d) { return std::chrono::duration<double>(d).count(); }
CoreClock::duration after(double s) {
  return std::chrono::duration_cast<CoreClock::duration>(std::chrono::duration<double>(s));
}

FramePtr encode(const wire::Message& m) {
  auto frame = wire::encode_frame(m, wire::kAbsoluteMaxFrameBytes);
  if (!frame) {
    log_event("encode_error",
              {{"type", wire::to_string(wire::message_type(m))}, {"error", frame.error().describe()}});
    return nullptr;
  }
  return std::make_shared<const std::vector<uint8_t>>(std::move(*frame));
}

}  // namespace

ReplicationCore::ReplicationCore(ServerConfig config, OpenedStorage opened, CoreTime now,
                                 const TransportCounters* transport)
    : config_(std::move(config)),
      storage_(std::move(opened.storage)),
      terrain_(std::move(opened.terrain)),
      frames_(config_.region_cache_bytes, config_.best_after_uses),
      history_(config_.history_changes_per_tile, config_.history_tiles, config_.history_bytes),
      transport_(transport ? transport : &no_transport_),
      started_(now),
      last_snapshot_time_(now) {
  // Ticks continue the log's: its writer refuses a tick that goes backwards, and a restarted
  // server must be able to log at once.
  tick_ = storage_.last_tick();
  // serve() reports bad tokens before it gets here; a caller that did not is failed closed.
  auto access = load_access_tokens(config_);
  if (access)
    access_ = std::move(*access);
  else
    access_.deny_all = true;
  // A base that costs something to read (a refined source, a pack) gets a worker that makes
  // the tiles admitted stamps and new subscriptions will read before the tick reads them.
  if (config_.prefetch_tiles > 0 && !terrain_.world().base().uniform()) {
    prefetch_ = std::make_shared<PrefetchingBase>(terrain_.world().base_ptr(), config_.prefetch_tiles);
    terrain_.mutable_world().replace_base(prefetch_);
  }
  sequenced_seq_ = published_seq_ = terrain_.last_seq();
  applier_ = std::make_unique<ApplyWorker>(terrain_, config_.history_bytes / 8);
  refresh_world_counters();
}

void ReplicationCore::refresh_world_counters() {
  const World& w = terrain_.world();
  world_counters_ = {w.edited_bytes(), w.base_cache_bytes(), w.base_tiles_generated(), w.unpersisted_bytes(),
                     w.edited_tiles_loaded()};
}

const ClientTiles* ReplicationCore::tiles_of(ClientId id) const {
  const auto it = clients_.find(id);
  return it == clients_.end() ? nullptr : &it->second.tiles;
}

bool ReplicationCore::in_handshake(ClientId id) const {
  const auto it = clients_.find(id);
  return it != clients_.end() && it->second.state == Client::State::kHandshake;
}

// --- Output ---

void ReplicationCore::send_frame(ClientId id, FramePtr frame) {
  if (frame) out_.frames.emplace_back(id, std::move(frame));
}

void ReplicationCore::send(Client& c, const wire::Message& m) { send_frame(c.id, encode(m)); }

void ReplicationCore::violation(Client& c, wire::WireErrorCode code, const std::string& field,
                                const std::string& text) {
  ++stats_.violations;
  ++c.violations;
  log_event(
      "violation",
      {{"client", std::to_string(c.id)}, {"code", wire::to_string(code)}, {"field", field}, {"text", text}});
  send(c, wire::ErrorMsg{code, field.substr(0, wire::kMaxFieldNameBytes),
                         text.substr(0, wire::kMaxErrorTextBytes)});
}

void ReplicationCore::fatal(Client& c, wire::WireErrorCode code, const std::string& field,
                            const std::string& text, wire::ByeReason reason) {
  violation(c, code, field, text);
  send(c, wire::Bye{reason, text.substr(0, wire::kMaxErrorTextBytes)});
  close(c.id, text);
}

// The client leaves the core at once; its queued deforms stay (they were validated and may
// already be in this tick) and their acks go nowhere.
bool ReplicationCore::erase_client(ClientId id) {
  const auto it = clients_.find(id);
  if (it == clients_.end()) return false;
  if (const auto k = key_owner_.find(it->second.resume_key); k != key_owner_.end() && k->second == id)
    key_owner_.erase(k);
  if (it->second.state == Client::State::kHandshake) {
    --handshakes_;
    const auto a = handshakes_by_address_.find(it->second.address);
    if (a != handshakes_by_address_.end() && --a->second == 0) handshakes_by_address_.erase(a);
  } else {
    --sessions_;
  }
  clients_.erase(it);
  return true;
}

void ReplicationCore::close(ClientId id, const std::string& reason) {
  if (!erase_client(id)) return;
  ++stats_.disconnects;
  log_event("disconnect", {{"client", std::to_string(id)}, {"reason", reason}});
  out_.closes.emplace_back(id, reason);
}

void ReplicationCore::disconnected(ClientId id, const std::string& reason) {
  if (!erase_client(id)) return;
  ++stats_.disconnects;
  log_event("disconnect", {{"client", std::to_string(id)}, {"reason", reason}});
}

// --- Admission ---

namespace {

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
  log_event("connect", {{"client", std::to_string(c.id)}, {"peer", peer}});
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
  // The stream cannot be trusted to be in sync any more: Error, Bye, close.
  fatal(it->second, wire::to_wire(e.code), e.field, e.describe(), wire::ByeReason::kProtocolError);
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

void ReplicationCore::receive(ClientId id, const wire::Message& m, CoreTime now, UnixMicros wall) {
  const auto it = clients_.find(id);
  if (it == clients_.end()) return;
  Client& c = it->second;
  const wire::MessageType type = wire::message_type(m);
  if (c.state == Client::State::kHandshake && type != wire::MessageType::kHello) {
    fatal(c, wire::WireErrorCode::kInvalidArgument, "hello",
          std::string("expected Hello, got ") + wire::to_string(type), wire::ByeReason::kProtocolError);
    return;
  }
  if (!admit_request(c, type, now)) return;
  switch (type) {
    case wire::MessageType::kHello:
      if (c.state != Client::State::kHandshake) {
        violation(c, wire::WireErrorCode::kInvalidArgument, "hello", "Hello after the handshake");
        return;
      }
      on_hello(c, std::get<wire::Hello>(m));
      return;
    case wire::MessageType::kPing:
      // The wall clock: Pong's server time is for the client's clock-offset estimate.
      send(c, wire::Pong{std::get<wire::Ping>(m).client_time_us, wall});
      return;
    case wire::MessageType::kBye: close(id, "client said bye: " + std::get<wire::Bye>(m).text); return;
    case wire::MessageType::kSubscribe:
    case wire::MessageType::kUnsubscribe: receive_subscription(c, m); return;
    case wire::MessageType::kDeform: on_deform(c, std::get<wire::Deform>(m), now); return;
    case wire::MessageType::kStampImageRequest:
      on_stamp_image(c, std::get<wire::StampImageRequest>(m));
      return;
    case wire::MessageType::kError:
      log_event("client_error", {{"client", std::to_string(id)}, {"text", std::get<wire::ErrorMsg>(m).text}});
      return;
    case wire::MessageType::kPong: return;
    case wire::MessageType::kStatsRequest:
      send(c, stats_message(std::get<wire::StatsRequest>(m).request_id, now));
      return;
    case wire::MessageType::kStampImageListRequest:
      on_stamp_image_list(c, std::get<wire::StampImageListRequest>(m));
      return;
    default:
      violation(c, wire::WireErrorCode::kUnknownType, "type",
                std::string(wire::to_string(type)) + " is a server-to-client message");
      return;
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
  if (h.version_major != wire::kProtocolMajor) {
    log_event("reject", {{"client", std::to_string(c.id)},
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
  log_event("hello",
            {{"client", std::to_string(c.id)}, {"name", c.name}, {"role", wire::to_string(granted)}});
}

bool ReplicationCore::valid_tile(const TileCoord& t) const {
  const WorldParams& p = terrain_.world().params();
  if (t.layer == Layer::kCoarse) return t.mip < p.mip_count() && p.tile_range(t.mip).contains(t.tx, t.ty);
  return t.mip == 0 && tiles_overlapping(p.detail_sample_rect()).contains(t.tx, t.ty);
}

void ReplicationCore::receive_subscription(Client& c, const wire::Message& m) {
  if (applier_->busy() || !deferred_subscriptions_.empty()) {
    deferred_subscriptions_.emplace_back(c.id, m);
    return;
  }
  if (const auto* sub = std::get_if<wire::Subscribe>(&m)) {
    on_subscribe(c, *sub);
    return;
  }
  for (const TileCoord& t : std::get<wire::Unsubscribe>(m).tiles) c.tiles.unsubscribe(t);
}

void ReplicationCore::run_deferred_subscriptions() {
  for (const auto& [id, m] : std::exchange(deferred_subscriptions_, {})) {
    const auto it = clients_.find(id);
    if (it != clients_.end() && it->second.state == Client::State::kReady)
      receive_subscription(it->second, m);
  }
}

void ReplicationCore::on_subscribe(Client& c, const wire::Subscribe& sub) {
  if (sub.focus) {
    const double mps = terrain_.world().params().meters_per_sample;
    c.tiles.set_focus(std::make_pair(sub.focus->x_m / mps, sub.focus->y_m / mps));
  }
  for (const wire::SubscribeEntry& e : sub.entries) {
    if (!valid_tile(e.tile)) {
      violation(c, wire::WireErrorCode::kOutOfWorld, "subscribe.tile",
                "tile " + to_string(e.tile) + " is not in the world");
      continue;
    }
    if (!c.tiles.subscribed(e.tile) && c.tiles.size() >= config_.max_subscriptions) {
      violation(c, wire::WireErrorCode::kOversize, "subscribe.entries",
                "subscription cap of " + std::to_string(config_.max_subscriptions) + " tiles reached");
      return;
    }
    // A client that already holds the current version (the initial terrain's 0 included)
    // resumes without a transfer; otherwise the whole tile is due (it leaves under the budget).
    const std::optional<uint64_t> held = e.held ? std::optional<uint64_t>(e.held_version) : std::nullopt;
    // Resuming behind: only the samples changed since, when the history reaches back that far.
    c.tiles.subscribe(e.tile, held, terrain_.world().tile_version(e.tile),
                      held ? history_.changed_since(e.tile, *held) : std::nullopt);
  }
  // The tiles this subscription will read (hashes, regions) get made ahead, off this thread.
  if (prefetch_) {
    std::vector<TileCoord> ahead;
    for (const wire::SubscribeEntry& e : sub.entries) {
      if (e.tile.layer == Layer::kCoarse && valid_tile(e.tile) &&
          terrain_.world().needs_base_read(e.tile.mip, e.tile.tx, e.tile.ty))
        ahead.push_back(e.tile);
    }
    prefetch_->prefetch(ahead);
  }
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
    log_event("deform_rejected", {{"client", std::to_string(c.id)},
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

void ReplicationCore::on_stamp_image(Client& c, const wire::StampImageRequest& r) {
  wire::StampImageResponse resp;
  resp.image_id = r.image_id;
  const StampTexture* t = terrain_.textures().find(r.image_id);
  if (t && t->width <= int32_t(wire::kMaxStampImageSide) && t->height <= int32_t(wire::kMaxStampImageSide)) {
    resp.found = true;
    resp.width = uint16_t(t->width);
    resp.height = uint16_t(t->height);
    resp.format = wire::StampImageFormat::kGray16;
    resp.pixels.resize(t->samples.size() * 2);
    std::memcpy(resp.pixels.data(), t->samples.data(), resp.pixels.size());
  }
  send(c, resp);
}

void ReplicationCore::on_stamp_image_list(Client& c, const wire::StampImageListRequest& r) {
  wire::StampImageList list;
  list.request_id = r.request_id;
  for (const StampTexture* t : terrain_.textures().all()) {
    if (list.images.size() == wire::kMaxStampImageListEntries) break;
    list.images.push_back({t->id, uint32_t(t->width), uint32_t(t->height)});
  }
  send(c, list);
}

// --- The tick ---

void ReplicationCore::acknowledge(const PendingDeform& p, std::optional<uint64_t> seq) {
  wire::DeformAck ack;
  ack.client_seq = p.client_seq;
  ack.accepted = seq.has_value();
  if (seq) {
    ack.global_seq = *seq;
  } else {
    ack.reject_code = wire::WireErrorCode::kIo;
    ack.field = "storage.unavailable";
  }
  if (p.key != 0) ledger_.answered(p.key, ack);
  // The sender, or the newest connection of its resume key when it has reconnected since.
  ClientId to = p.client;
  if (p.key != 0) {
    if (const auto k = key_owner_.find(p.key); k != key_owner_.end()) to = k->second;
  }
  const auto it = clients_.find(to);
  if (it == clients_.end()) return;
  Client& c = it->second;
  if (to == p.client && c.unacked > 0) --c.unacked;  // its slot; a new connection never took one
  send(c, ack);
}

bool ReplicationCore::begin_tick(CoreTime now) {
  if (stopping_ || failed_) return false;
  ++tick_;
  // This tick's stamps, in order, up to the tick's cost budget (at least one): the rest wait,
  // and all wait while a tick's worth is already sequenced and waiting for the apply worker.
  size_t n = 0;
  uint64_t spent = 0;
  while (n < pending_.size() && to_apply_cost_ < config_.tick_stamp_cost &&
         (n == 0 || spent + pending_[n].cost <= config_.tick_stamp_cost))
    spent += pending_[n++].cost;
  committing_.assign(std::make_move_iterator(pending_.begin()),
                     std::make_move_iterator(pending_.begin() + ptrdiff_t(n)));
  pending_.erase(pending_.begin(), pending_.begin() + ptrdiff_t(n));
  last_batch_ = committing_.size();
  tick_start_counters_ = world_counters_;
  tick_base_tiles_read_ = tick_edited_tiles_loaded_ = 0;
  if (!storage_.writable()) try_resume_storage(now);
  if (committing_.empty() || !storage_.writable()) return true;
  // 1. Sequence and log the whole tick (commit() syncs it once: the durability point).
  uint64_t seq = sequenced_seq_;
  for (const PendingDeform& p : committing_) {
    const Status st = storage_.append({++seq, tick_, p.client, p.stamp});
    if (!st.ok()) {  // a broken invariant (sequence or tick), not the disk
      log_event("fatal", {{"error", st.error().describe()}});
      failed_ = true;
      committing_.clear();
      shutdown("log append failed", now, 0);
      return false;
    }
  }
  return true;
}

void ReplicationCore::refuse(const std::vector<PendingDeform>& batch) {
  for (const PendingDeform& p : batch) {
    ++stats_.deforms_rejected;
    ++stats_.deforms_rejected_by[wire::to_string(wire::WireErrorCode::kIo)];
    acknowledge(p, std::nullopt);
  }
}

bool ReplicationCore::commit(CoreTime now) {
  if (committing_.empty() || failed_) return false;
  const std::vector<PendingDeform> batch = std::exchange(committing_, {});
  if (!storage_.writable()) {
    refuse(batch);
    return false;
  }
  if (const Status st = storage_.sync(); !st.ok()) {
    // A full disk or an I/O error: nothing of this tick is durable (the writer cut the file
    // back), so nothing of it is applied or acknowledged. The server keeps serving reads and
    // hashes, refuses edits, and retries the log with a growing interval.
    log_event("storage_unavailable",
              {{"error", st.error().describe()}, {"refused", std::to_string(batch.size())}});
    ++stats_.storage_failures;
    resume_backoff_s_ = kResumeBackoffMinS;
    next_resume_try_ = now + after(resume_backoff_s_);
    refuse(batch);
    return false;
  }
  // 2. Acknowledge: durable and sequenced is what an ack promises, so the acks leave now,
  // before the tick's stamps are applied (a costly one delays only the events and regions).
  for (const PendingDeform& p : batch) {
    ++stats_.deforms_accepted;
    acknowledge(p, ++sequenced_seq_);
    to_apply_.push_back({sequenced_seq_, p.client, p.stamp});
    to_apply_cost_ += p.cost;
  }
  return true;
}

bool ReplicationCore::advance_apply() {
  while (true) {
    if (applier_->busy()) {
      auto done = applier_->take();
      if (!done) return false;
      publish(std::move(*done));
    }
    if (to_apply_.empty()) return true;
    applier_->start(std::exchange(to_apply_, {}));
    to_apply_cost_ = 0;
  }
}

void ReplicationCore::finish_applying() {
  while (!advance_apply()) applier_->wait();
}

void ReplicationCore::stream(CoreTime now, const std::function<uint64_t(ClientId)>& unsent) {
  if (stopping_ || failed_) return;
  run_deferred_subscriptions();
  frames_.adopt_best();
  stream_regions(now, unsent);
  if (config_.hashes_every_ticks > 0 && tick_ % config_.hashes_every_ticks == 0) {
    uint32_t base_reads_left = kHashBaseReadsPerRound;
    std::vector<TileCoord> later;
    for (auto& [id, c] : clients_) {
      if (c.state == Client::State::kReady && c.tiles.size() != 0) send_hashes(c, base_reads_left, later);
    }
    if (prefetch_ && !later.empty()) prefetch_->prefetch(later);
  }
}

void ReplicationCore::persist(CoreTime now, UnixMicros wall) {
  if (stopping_ || failed_) return;
  maybe_snapshot(now, wall, false);
}

void ReplicationCore::trim() {
  if (stopping_ || failed_) return;
  // Clean base tiles read this tick (subscriptions, stamps' neighbourhoods) back under budget;
  // nothing holds a span into them between ticks.
  terrain_.mutable_world().trim_base_cache();
  refresh_world_counters();
  tick_base_tiles_read_ = world_counters_.base_tiles_generated - tick_start_counters_.base_tiles_generated;
  tick_edited_tiles_loaded_ = world_counters_.edited_tiles_loaded - tick_start_counters_.edited_tiles_loaded;
}

bool run_tick(ReplicationCore& core, CoreTime now, UnixMicros wall, const TickHooks& hooks) {
  const auto done = [&](TickPhase p) {
    if (hooks.phase_done) hooks.phase_done(p);
  };
  if (!core.begin_tick(now)) return false;
  done(TickPhase::kLogged);
  const bool acks = core.commit(now);
  done(TickPhase::kSynced);
  if (core.failed()) return false;
  if (acks && hooks.acks_ready) hooks.acks_ready();
  done(TickPhase::kCommitted);
  bool world_free = core.advance_apply();
  while (!world_free) {
    ApplyWorker* worker = core.applying();
    if (worker == nullptr || !hooks.wait_for_apply || !hooks.wait_for_apply(*worker)) break;
    world_free = core.advance_apply();
  }
  done(TickPhase::kApplied);
  // The apply goes on: what needs its result waits for a later tick.
  if (!world_free) return false;
  core.stream(now, hooks.unsent);
  done(TickPhase::kStreamed);
  core.persist(now, wall);
  done(TickPhase::kPersisted);
  core.trim();
  done(TickPhase::kTrimmed);
  return true;
}

// 3. Applied (on the worker, in order): the history, the events (one encoding for every
// client), the plans.
void ReplicationCore::publish(std::vector<ApplyWorker::Output> applied) {
  for (ApplyWorker::Output& o : applied) {
    published_seq_ = o.seq;
    for (const Error& e : o.backend_failures)
      log_event("backend_error",
                {{"seq", std::to_string(o.seq)}, {"error", e.describe()}, {"fallback", "cpu"}});
    if (!o.applied) {
      log_event("apply_error", {{"seq", std::to_string(o.seq)}, {"error", o.applied.error().describe()}});
      continue;
    }
    const AppliedStamp& a = *o.applied;
    history_.record(a.changes, o.before);
    wire::DeformEvent ev;
    ev.global_seq = a.seq;
    ev.origin_client_id = a.client_id;
    ev.stamp = a.stamp;
    ev.contact = a.contact;
    ev.base_versions = a.base_versions;
    if (ev.base_versions.size() > wire::kMaxEventTiles) ev.base_versions.clear();  // regions only
    FramePtr frame = encode(ev);
    if (!frame) ev.base_versions.clear();  // no event then: the plan sends regions
    for (auto& [id, c] : clients_) {
      if (c.state != Client::State::kReady) continue;
      if (!c.tiles.plan_event(ev, a.changes)) continue;
      if (frame) {
        send_frame(id, frame);
        ++stats_.events_sent;
      }
    }
  }
}

void ReplicationCore::stream_regions(CoreTime now, const std::function<uint64_t(ClientId)>& unsent) {
  // Every client's turn in a rotating order; within a client, its due tiles in order, while
  // its byte budget has credit. Encodes (cache misses) are bounded per tick for everyone.
  std::vector<ClientId> order;
  for (auto& [id, c] : clients_) {
    if (c.state == Client::State::kReady) order.push_back(id);
  }
  if (order.empty()) return;
  std::rotate(order.begin(), order.begin() + ptrdiff_t(stream_cursor_ % order.size()), order.end());
  ++stream_cursor_;
  const double budget = double(config_.client_bytes_per_second);
  uint32_t encodes_left = config_.max_encodes_per_tick;
  for (const ClientId id : order) {
    Client& c = clients_.at(id);
    c.credit.refill(now);
    if (c.tiles.due_count() == 0) continue;
    // A client that does not read gets no more bulk: only what must go.
    const uint64_t queued = unsent ? unsent(id) : 0;
    if (budget > 0 && double(queued) > budget) continue;
    for (const TileCoord& t : c.tiles.due_in_order()) {
      if (budget > 0 && c.credit.level() <= 0) break;
      const RegionNeed need = c.tiles.need(
          t, [&](const TileCoord& tile, uint64_t held) { return history_.can_rebuild(tile, held); });
      Frames frames;
      if (encodes_left == 0) {
        // Out of encodes this tick: only what the cache already holds may still go.
        frames = frames_.cached(terrain_.world(), t, need.base, need.rect);
        if (frames.empty()) break;
      } else {
        bool encoded = false;
        auto got = frames_.get(terrain_.world(), &history_, t, need.base, need.rect, &encoded);
        if (encoded) --encodes_left;
        if (!got) {
          log_event("encode_error", {{"tile", to_string(t)}, {"error", got.error().describe()}});
          c.tiles.unsubscribe(t);  // cannot be served: stop planning it rather than retry forever
          continue;
        }
        frames = std::move(*got);
      }
      for (const FramePtr& f : frames) {
        send_frame(id, f);
        c.credit.spend(double(f->size()));
      }
      c.tiles.mark_sent(t, terrain_.world().tile_state(t).version);
      ++stats_.regions_sent;
      if (need.base) ++stats_.partial_regions_sent;
    }
  }
}

void ReplicationCore::send_hashes(Client& c, uint32_t& base_reads_left, std::vector<TileCoord>& later) {
  wire::TileHashes msg;
  for (const auto& [t, interest] : c.tiles.tiles()) {
    // An untouched tile whose hash is not known costs a generation or a pack read: the round
    // makes a few, and the rest are made ahead and hashed in a later round.
    std::optional<TileState> st = terrain_.world().known_tile_state(t);
    if (!st) {
      if (base_reads_left == 0) {
        later.push_back(t);
        continue;
      }
      --base_reads_left;
      st = terrain_.world().tile_state(t);
    }
    msg.entries.push_back({t, st->version, st->hash});
    if (msg.entries.size() == wire::kMaxTileHashEntries) {
      send(c, msg);
      msg.entries.clear();
    }
  }
  if (!msg.entries.empty()) send(c, msg);
}

void ReplicationCore::try_resume_storage(CoreTime now) {
  if (now < next_resume_try_) return;
  if (const Status st = storage_.resume(sequenced_seq_); !st.ok()) {
    resume_backoff_s_ = std::min(resume_backoff_s_ * 2.0, kResumeBackoffMaxS);
    next_resume_try_ = now + after(resume_backoff_s_);
    log_event("storage_retry",
              {{"error", st.error().describe()}, {"next_in_s", std::to_string(resume_backoff_s_)}});
    return;
  }
  log_event("storage_resumed", {{"seq", std::to_string(sequenced_seq_)}});
}

void ReplicationCore::maybe_snapshot(CoreTime now, UnixMicros wall, bool force) {
  // A snapshot reads and adopts into the world, at the applied sequence: only while no apply
  // runs and nothing sequenced waits for one (the log's next segment starts after it).
  if (applier_->busy() || !to_apply_.empty()) return;
  // A snapshot being written on its worker: adopted once written (at shutdown, waited for).
  if (storage_.snapshot_in_flight()) {
    auto done = storage_.poll_snapshot(terrain_, force);
    if (!done) return;
    snapshot_done(*done, now);
    if (!force) return;
  }
  if (!storage_.writable()) return;  // the log must be writable to start the next segment
  if (!force && now < snapshot_retry_after_) return;
  const uint64_t since = terrain_.last_seq() - storage_.last_snapshot_seq();
  const double age = seconds(now - last_snapshot_time_);
  // Edited tiles no snapshot holds cannot be evicted: past the dirty budget, a snapshot makes
  // them clean so the world stays within its cache budget.
  const bool dirty_full = config_.snapshot_dirty_bytes > 0 &&
                          terrain_.world().unpersisted_bytes() >= config_.snapshot_dirty_bytes;
  const bool due = force || dirty_full ||
                   (config_.snapshot_every_stamps > 0 && since >= config_.snapshot_every_stamps) ||
                   (config_.snapshot_interval_s > 0 && age >= config_.snapshot_interval_s && since > 0);
  // Nothing new since the last snapshot (or since the initial terrain, which segment 0's
  // header already describes): a snapshot would add nothing.
  if (!due || since == 0 || terrain_.last_seq() == 0) return;
  snapshot_started_ = now;  // for the log line only
  last_snapshot_time_ = now;
  // The tick thread copies what changed and starts the next segment; the encoding and writing
  // run on the storage's worker, so acks and events do not wait for them.
  const Status begun = storage_.begin_snapshot(terrain_, tick_, wall);
  if (!begun.ok()) {
    snapshot_done(Result<SnapshotOutcome>(begun.error()), now);
    return;
  }
  if (force || !config_.async_snapshots) snapshot_done(*storage_.poll_snapshot(terrain_, true), now);
}

void ReplicationCore::snapshot_done(const Result<SnapshotOutcome>& done, CoreTime now) {
  if (!done) {
    // Nothing is left behind (a failed write removes what it wrote); retrying at once on a
    // full disk would only churn, so the interval grows.
    snapshot_backoff_s_ = snapshot_backoff_s_ == 0
                              ? kSnapshotBackoffMinS
                              : std::min(snapshot_backoff_s_ * 2.0, kSnapshotBackoffMaxS);
    snapshot_retry_after_ = now + after(snapshot_backoff_s_);
    log_event("snapshot_error",
              {{"error", done.error().describe()}, {"retry_in_s", std::to_string(snapshot_backoff_s_)}});
    return;
  }
  snapshot_backoff_s_ = 0;
  const SnapshotWrite& w = done->write;
  stats_.snapshot_bytes_written += w.written_bytes;
  ++stats_.snapshots;
  log_event(
      "snapshot",
      {{"path", w.path},
       {"seq", std::to_string(w.last_seq)},
       {"tiles", std::to_string(w.tiles_written)},
       {"tile_bytes", std::to_string(w.tile_bytes)},
       {"moved_bytes", std::to_string(w.moved_bytes)},
       {"index_bytes", std::to_string(w.index_bytes)},
       {"written_bytes", std::to_string(w.written_bytes)},
       {"snapshots_removed", std::to_string(done->prune.snapshots_removed)},
       {"tile_files_removed", std::to_string(done->prune.tile_files_removed)},
       {"segments_removed", std::to_string(done->segments_removed)},
       // From the tick that began it to the one that adopted it (0: written within one call).
       {"ms", std::to_string(std::chrono::duration<double, std::milli>(now - snapshot_started_).count())}});
}

void ReplicationCore::record_tick(const TickTimes& p) {
  const double ms = p.total_ms;
  tick_ms_.push_back(ms);
  ticks_.add(ms);
  if (ms > 1000.0 / config_.tick_hz) {
    ++stats_.tick_overruns;
    log_event("tick_overrun", {{"tick", std::to_string(tick_)},
                               {"ms", fmt_ms(ms)},
                               {"stamps", std::to_string(last_batch_)},
                               {"sync_ms", fmt_ms(p.sync_ms)},
                               {"commit_ms", fmt_ms(p.commit_ms)},
                               {"apply_wait_ms", fmt_ms(p.apply_wait_ms)},
                               {"applying", p.world_busy ? "yes" : "no"},
                               {"stream_ms", fmt_ms(p.stream_ms)},
                               {"snapshot_ms", fmt_ms(p.snapshot_ms)},
                               {"trim_ms", fmt_ms(p.trim_ms)},
                               {"base_tiles_read", std::to_string(tick_base_tiles_read_)},
                               {"edited_tiles_loaded", std::to_string(tick_edited_tiles_loaded_)}});
  }
}

MetricsSnapshot ReplicationCore::metrics() const {
  MetricsSnapshot m;
  // The counters (counters.h): the core's own and the transport's, as they stand.
#define LOAM_COUNTER_COPY_core(name) m.name = stats_.name;
#define LOAM_COUNTER_COPY_transport(name) m.name = transport_->name;
#define LOAM_COUNTER_COPY_state(name)
#define LOAM_X(name, source, line, metric, type, help, wire) LOAM_COUNTER_COPY_##source(name)
  LOAM_SERVER_COUNTERS(LOAM_X)
#undef LOAM_X
#undef LOAM_COUNTER_COPY_core
#undef LOAM_COUNTER_COPY_transport
#undef LOAM_COUNTER_COPY_state
  m.deforms_rejected_by = stats_.deforms_rejected_by;
  // The rows read from the core's state.
  m.sessions = sessions_;
  m.handshakes = handshakes_;
  m.clients = clients_.size();
  m.seq = published_seq_;
  const RegionFrameCounters& rc = frames_.counters();
  m.region_encodes = rc.encodes;
  m.region_cache_hits = rc.hits;
  m.region_deltas = rc.delta_encodes;
  m.region_best_upgrades = rc.best_upgrades;
  m.region_best_bytes_saved = rc.best_bytes_saved;
  m.region_cache_bytes = rc.bytes_held;
  m.history_bytes = history_.bytes();
  m.edited_tile_bytes = world_counters_.edited_bytes;
  m.base_cache_bytes = world_counters_.base_cache_bytes;
  m.base_tiles_generated = world_counters_.base_tiles_generated;
  m.unpersisted_tile_bytes = world_counters_.unpersisted_bytes;
  m.edited_tiles_loaded = world_counters_.edited_tiles_loaded;
  if (prefetch_) {
    const PrefetchingBase::Stats ps = prefetch_->stats();
    m.prefetch_queued = ps.queued;
    m.prefetch_hits = ps.ready_hits;
    m.prefetch_inline = ps.made_inline;
  }
  m.snapshot_store_bytes = storage_.store().file_bytes();
  m.snapshot_live_bytes = storage_.store().live_bytes();
  m.pending_deforms = pending_.size();
  for (const PendingDeform& p : pending_) m.pending_stamp_cost += p.cost;
  m.snapshot_sequence = storage_.last_snapshot_seq();
  m.ticks = ticks_;
  return m;
}

void ReplicationCore::report_stats(CoreTime) {
  flush_suppressed_log_lines();
  std::vector<double> t = std::move(tick_ms_);
  tick_ms_.clear();
  std::sort(t.begin(), t.end());
  last_p50_ms_ = percentile(t, 0.5);
  last_p99_ms_ = percentile(t, 0.99);
  // The counters from the table; the tick percentiles and the storage's state between them.
  const auto fields =
      stats_line_fields(metrics(), {{27, "tick_p50_ms", std::to_string(last_p50_ms_)},
                                    {28, "tick_p99_ms", std::to_string(last_p99_ms_)},
                                    {29, "storage", storage_.writable() ? "ok" : "refusing edits"}});
  log_event("stats", fields);
}

namespace {

// wire::Stats with a field that takes the table's rows that are not sent (wire `none`).
struct StatsFields : wire::Stats {
  uint64_t none = 0;
};

}  // namespace

wire::Stats ReplicationCore::stats_message(uint32_t request_id, CoreTime now) const {
  const MetricsSnapshot m = metrics();
  StatsFields st;
#define LOAM_X(name, source, line, metric, type, help, wire) st.wire = decltype(st.wire)(m.name);
  LOAM_SERVER_COUNTERS(LOAM_X)
#undef LOAM_X
  st.request_id = request_id;
  // Without a completed stats period yet, report the ticks so far.
  double p50 = last_p50_ms_, p99 = last_p99_ms_;
  if (p50 == 0 && !tick_ms_.empty()) {
    std::vector<double> t = tick_ms_;
    std::sort(t.begin(), t.end());
    p50 = percentile(t, 0.5);
    p99 = percentile(t, 0.99);
  }
  st.tick_p50_us = uint32_t(p50 * 1000.0);
  st.tick_p99_us = uint32_t(p99 * 1000.0);
  st.uptime_ms = uint64_t(std::chrono::duration_cast<std::chrono::milliseconds>(now - started_).count());
  st.client_bytes_per_second = config_.client_bytes_per_second;
  return st;
}

void ReplicationCore::reload_tokens() {
  auto access = load_access_tokens(config_);
  if (!access) {
    // The tokens in force stay: a half-written secret must not lock everyone out.
    log_event("tokens_reload_failed", {{"error", access.error().describe()}});
    return;
  }
  access_ = std::move(*access);
  warn_if_tokens_file_exposed();
  log_event("tokens_reloaded", {{"access", access_.required() ? "tokens" : "open"},
                                {"editor_tokens", std::to_string(access_.editors.size())},
                                {"viewer_tokens", std::to_string(access_.viewers.size())}});
}

void ReplicationCore::warn_if_tokens_file_exposed() {
  if (config_.tokens_file.empty()) return;
  if (const auto mode = tokens_file_exposure(config_.tokens_file)) {
    log_event("warning", {{"tokens_file", config_.tokens_file},
                          {"mode", *mode},
                          {"what", "the tokens file is readable by its group or others: chmod 600 it"}});
  }
}

void ReplicationCore::shutdown(const std::string& reason, CoreTime now, UnixMicros wall) {
  if (stopping_) return;
  stopping_ = true;
  log_event("shutdown", {{"reason", reason}});
  if (!failed_) {
    // Stamps still queued were never acknowledged: dropping them loses nothing promised. Those
    // acknowledged are applied (their events go out before the Bye) and the snapshot holds them.
    pending_.clear();
    finish_applying();
    if (storage_.writable()) {
      if (const Status st = storage_.sync(); !st.ok()) log_event("fatal", {{"error", st.error().describe()}});
    }
    maybe_snapshot(now, wall, true);
  }
  std::vector<ClientId> all;
  for (const auto& [id, c] : clients_) all.push_back(id);
  for (const ClientId id : all) {
    send(clients_.at(id), wire::Bye{wire::ByeReason::kShutdown, "server shutting down: " + reason});
    close(id, "server shutdown");
  }
}

}  // namespace loam::server
