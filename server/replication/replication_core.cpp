#include "server/replication/replication_core.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>

#include "protocol/hex64.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/wire/framing.h"
#include "server/replication/core_detail.h"

namespace loam::server {

FramePtr core_detail::encode(const wire::Message& m, CoreOutput& out) {
  auto frame = wire::encode_frame(m, wire::kAbsoluteMaxFrameBytes);
  if (!frame) {
    out.log.push_back(
        {"encode_error",
         {{"type", wire::to_string(wire::message_type(m))}, {"error", frame.error().describe()}}});
    return nullptr;
  }
  return std::make_shared<const std::vector<uint8_t>>(std::move(*frame));
}

using namespace core_detail;

namespace {

// serve() reports bad tokens before the core is made; a caller that did not is failed closed.
AccessTokens access_or_none(const ServerConfig& config) {
  auto access = load_access_tokens(config);
  if (access) return std::move(*access);
  AccessTokens none;
  none.deny_all = true;
  return none;
}

}  // namespace

ReplicationCore::ReplicationCore(ServerConfig config, OpenedStorage opened, CoreTime now,
                                 const TransportCounters* transport)
    : config_(std::move(config)),
      storage_(std::move(opened.storage)),
      terrain_(std::move(opened.terrain)),
      admission_(config_, access_or_none(config_)),
      commits_(terrain_, config_.history_bytes / 8),
      streamer_(config_),
      snapshots_(config_, now),
      history_(config_.history_changes_per_tile, config_.history_tiles, config_.history_bytes),
      transport_(transport ? transport : &no_transport_),
      started_(now) {
  // Ticks continue the log's: its writer refuses a tick that goes backwards, and a restarted
  // server must be able to log at once.
  tick_ = storage_.last_tick();
  // A base that costs something to read (a refined source, a pack) gets a worker that makes
  // the tiles admitted stamps and new subscriptions will read before the tick reads them.
  if (config_.prefetch_tiles > 0 && !terrain_.world().base().uniform()) {
    prefetch_ = std::make_shared<PrefetchingBase>(terrain_.world().base_ptr(), config_.prefetch_tiles);
    terrain_.mutable_world().replace_base(prefetch_);
  }
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

void ReplicationCore::send(Client& c, const wire::Message& m) { send_frame(c.id, encode(m, out_)); }

void ReplicationCore::violation(Client& c, wire::WireErrorCode code, const std::string& field,
                                const std::string& text) {
  ++stats_.violations;
  ++c.violations;
  note("violation",
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
  commits_.release_key(it->second.resume_key, id);
  admission_.leave(it->second.address, it->second.state == Client::State::kReady);
  clients_.erase(it);
  return true;
}

void ReplicationCore::close(ClientId id, const std::string& reason) {
  if (!erase_client(id)) return;
  ++stats_.disconnects;
  note("disconnect", {{"client", std::to_string(id)}, {"reason", reason}});
  out_.closes.emplace_back(id, reason);
}

void ReplicationCore::disconnected(ClientId id, const std::string& reason) {
  if (!erase_client(id)) return;
  ++stats_.disconnects;
  note("disconnect", {{"client", std::to_string(id)}, {"reason", reason}});
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
      note("client_error", {{"client", std::to_string(id)}, {"text", std::get<wire::ErrorMsg>(m).text}});
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

void ReplicationCore::reload_tokens() {
  auto access = load_access_tokens(config_);
  if (!access) {
    // The tokens in force stay: a half-written secret must not lock everyone out.
    note("tokens_reload_failed", {{"error", access.error().describe()}});
    return;
  }
  admission_.set_access(std::move(*access));
  warn_if_tokens_file_exposed();
  const AccessTokens& a = admission_.access();
  note("tokens_reloaded", {{"access", a.required() ? "tokens" : "open"},
                           {"editor_tokens", std::to_string(a.editors.size())},
                           {"viewer_tokens", std::to_string(a.viewers.size())}});
}

void ReplicationCore::warn_if_tokens_file_exposed() {
  if (config_.tokens_file.empty()) return;
  if (const auto mode = tokens_file_exposure(config_.tokens_file)) {
    note("warning", {{"tokens_file", config_.tokens_file},
                     {"mode", *mode},
                     {"what", "the tokens file is readable by its group or others: chmod 600 it"}});
  }
}

void ReplicationCore::shutdown(const std::string& reason, CoreTime now, UnixMicros wall) {
  if (stopping_) return;
  stopping_ = true;
  note("shutdown", {{"reason", reason}});
  if (!failed_) {
    // Stamps still queued were never acknowledged: dropping them loses nothing promised. Those
    // acknowledged are applied (their events go out before the Bye) and the snapshot holds them.
    commits_.drop_queued();
    finish_applying();
    if (storage_.writable()) {
      if (const Status st = storage_.sync(); !st.ok()) note("fatal", {{"error", st.error().describe()}});
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
