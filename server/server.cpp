#include "server/server.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <set>

#include "protocol/codec/region_codec.h"
#include "protocol/hex64.h"
#include "protocol/tile_hash.h"
#include "protocol/tile_rect.h"
#include "server/event_log.h"

namespace loam::server {

using asio::ip::tcp;
using Clock = std::chrono::steady_clock;

namespace {

// Tracked version of a subscribed tile the server will replace with a region this tick.
constexpr uint64_t kNeedsRegion = ~uint64_t(0);

bool editor_role(wire::Role r) { return r != wire::Role::kSpectator; }

// The one percentile rule of the stats line and the Stats message (nearest rank below), so
// the two never disagree on the same ticks. `sorted` ascending; 0 when empty.
double percentile(const std::vector<double>& sorted, double p) {
  return sorted.empty() ? 0.0 : sorted[size_t(p * double(sorted.size() - 1))];
}

}  // namespace

struct Server::Session {
  enum class State { kHandshake, kReady, kClosing };
  explicit Session(tcp::socket s, asio::io_context& io, uint32_t max_frame)
      : socket(std::move(s)), assembler(max_frame), timer(io), linger(io) {}

  tcp::socket socket;
  wire::FrameAssembler assembler;
  asio::steady_timer timer;   // handshake, then idle timeout
  asio::steady_timer linger;  // bounds the time a closing session may take to flush
  std::array<uint8_t, 64 * 1024> read_buffer{};
  std::deque<std::vector<uint8_t>> out;
  uint64_t queued_bytes = 0;
  bool writing = false;
  State state = State::kHandshake;
  uint32_t id = 0;
  std::string name;
  std::string peer;
  wire::Role role = wire::Role::kPlayer;
  bool editor = true;
  std::map<TileCoord, uint64_t> subs;  // subscribed tile -> version the client holds
  double tokens = 0;
  Clock::time_point refill;
  // Deforms queued in pending_ whose DeformAck has not been sent yet: the
  // ServerLimits.max_pending_deforms the client was promised counts these, whichever tick
  // acknowledges them.
  uint32_t unacked_deforms = 0;
  uint64_t violations = 0;
  bool closed = false;
};

Server::Server(asio::io_context& io, ServerConfig config, OpenedStorage opened)
    : io_(io),
      config_(std::move(config)),
      storage_(std::move(opened.storage)),
      terrain_(std::move(opened.terrain)),
      acceptor_(io),
      tick_timer_(io),
      stats_timer_(io),
      signals_(io, SIGINT, SIGTERM),
      reload_signal_(io, SIGHUP) {
  last_snapshot_time_ = Clock::now();
  // Ticks continue the log's: its writer refuses a tick that goes backwards, and a restarted
  // server must be able to log at once.
  tick_ = storage_.last_tick();
  // serve() reports bad tokens before it gets here; a caller that did not is failed closed.
  auto access = load_access_tokens(config_);
  if (access)
    access_ = std::move(*access);
  else
    access_.deny_all = true;
}

Server::~Server() = default;

Status Server::start() {
  asio::error_code ec;
  const auto address = asio::ip::make_address(config_.bind_address, ec);
  if (ec) return make_error(ErrorCode::kInvalidArgument, "bind_address", ec.message());
  const tcp::endpoint ep(address, config_.port);
  acceptor_.open(ep.protocol(), ec);
  if (!ec) acceptor_.set_option(tcp::acceptor::reuse_address(true), ec);
  if (!ec) acceptor_.bind(ep, ec);
  if (!ec) acceptor_.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) {
    return make_error(ErrorCode::kIo, config_.bind_address + ":" + std::to_string(config_.port),
                      "cannot listen: " + ec.message());
  }
  port_ = acceptor_.local_endpoint().port();
  if (!config_.port_file.empty()) {
    const std::string tmp = config_.port_file + ".tmp";
    {
      std::ofstream f(tmp);
      f << port_ << "\n";
      if (!f) return make_error(ErrorCode::kIo, config_.port_file, "cannot write the port file");
    }
    std::rename(tmp.c_str(), config_.port_file.c_str());
  }
  signals_.async_wait([this](const asio::error_code& e, int sig) {
    if (!e) shutdown(sig == SIGINT ? "SIGINT" : "SIGTERM");
  });
  wait_for_reload();
  log_event("listening", {{"address", config_.bind_address},
                          {"port", std::to_string(port_)},
                          {"tick_hz", std::to_string(config_.tick_hz)},
                          {"last_seq", std::to_string(terrain_.last_seq())},
                          {"world_hash", hex64(terrain_.world().world_hash())},
                          {"access", access_.required() ? "tokens" : "open"},
                          {"editor_tokens", std::to_string(access_.editors.size())},
                          {"viewer_tokens", std::to_string(access_.viewers.size())}});
  if (!access_.required() && config_.bind_address != "127.0.0.1" && config_.bind_address != "::1" &&
      config_.bind_address != "localhost") {
    log_event("warning", {{"what",
                           "no tokens configured on a non-loopback address: anyone who reaches "
                           "this port can edit (docs/configuration.md, --tokens-file)"}});
  }
  warn_if_tokens_file_exposed();
  accept();
  next_tick_ = Clock::now();
  schedule_tick();
  if (config_.stats_interval_s > 0) {
    stats_timer_.expires_after(
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(config_.stats_interval_s)));
    stats_timer_.async_wait([this](const asio::error_code& e) {
      if (!e) report_stats();
    });
  }
  return {};
}

void Server::wait_for_reload() {
  reload_signal_.async_wait([this](const asio::error_code& e, int) {
    if (e) return;  // cancelled at shutdown
    reload_tokens();
    wait_for_reload();
  });
}

void Server::warn_if_tokens_file_exposed() {
  if (config_.tokens_file.empty()) return;
  if (const auto mode = tokens_file_exposure(config_.tokens_file)) {
    log_event("warning", {{"tokens_file", config_.tokens_file},
                          {"mode", *mode},
                          {"what", "the tokens file is readable by its group or others: chmod 600 it"}});
  }
}

void Server::reload_tokens() {
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

void Server::accept() {
  acceptor_.async_accept([this](const asio::error_code& ec, tcp::socket socket) {
    if (ec) {
      if (ec != asio::error::operation_aborted) log_event("accept_error", {{"error", ec.message()}});
      if (!stopping_ && ec != asio::error::operation_aborted) accept();
      return;
    }
    on_accept(std::move(socket));
    if (!stopping_) accept();
  });
}

void Server::on_accept(tcp::socket socket) {
  asio::error_code ec;
  socket.set_option(tcp::no_delay(true), ec);
  auto s = std::make_shared<Session>(std::move(socket), io_, config_.max_frame_bytes);
  s->id = next_client_id_++;
  const auto remote = s->socket.remote_endpoint(ec);
  s->peer = ec ? "?" : remote.address().to_string() + ":" + std::to_string(remote.port());
  s->tokens = config_.deform_burst;
  s->refill = Clock::now();
  ++stats_.connects;
  sessions_[s->id] = s;
  log_event("connect", {{"client", std::to_string(s->id)}, {"peer", s->peer}});
  if (sessions_.size() > config_.max_clients) {
    fatal(s, wire::WireErrorCode::kServerFull, "",
          "server full (" + std::to_string(config_.max_clients) + " clients)", wire::ByeReason::kKicked);
    return;
  }
  s->timer.expires_after(std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(config_.handshake_timeout_s)));
  std::weak_ptr<Session> weak = s;
  s->timer.async_wait([this, weak](const asio::error_code& e) {
    auto sp = weak.lock();
    if (e || !sp || sp->state != Session::State::kHandshake) return;
    fatal(sp, wire::WireErrorCode::kInvalidArgument, "hello", "no Hello within the handshake timeout",
          wire::ByeReason::kTimeout);
  });
  read(s);
}

void Server::arm_idle(const SessionPtr& s) {
  if (config_.idle_timeout_s <= 0) return;
  s->timer.expires_after(
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(config_.idle_timeout_s)));
  std::weak_ptr<Session> weak = s;
  s->timer.async_wait([this, weak](const asio::error_code& e) {
    auto sp = weak.lock();
    if (e || !sp || sp->state != Session::State::kReady) return;
    fatal(sp, wire::WireErrorCode::kInvalidArgument, "", "idle timeout", wire::ByeReason::kTimeout);
  });
}

void Server::read(const SessionPtr& s) {
  s->socket.async_read_some(asio::buffer(s->read_buffer), [this, s](const asio::error_code& ec, size_t n) {
    if (s->closed) return;
    if (ec) {
      close(s, ec == asio::error::eof ? "peer closed" : "read error: " + ec.message());
      return;
    }
    on_bytes(s, n);
    if (!s->closed && s->state != Session::State::kClosing) read(s);
  });
}

void Server::on_bytes(const SessionPtr& s, size_t n) {
  stats_.bytes_in += n;
  s->assembler.feed(std::span(s->read_buffer.data(), n));
  if (s->state == Session::State::kReady) arm_idle(s);
  while (s->state != Session::State::kClosing) {
    auto next = s->assembler.next_message();
    if (!next) {
      // The stream cannot be trusted to be in sync any more: Error, Bye, close.
      fatal(s, wire::to_wire(next.error().code), next.error().field, next.error().describe(),
            wire::ByeReason::kProtocolError);
      return;
    }
    if (!next->has_value()) return;
    handle(s, **next);
  }
}

void Server::handle(const SessionPtr& s, wire::Message& m) {
  const wire::MessageType type = wire::message_type(m);
  if (s->state == Session::State::kHandshake && type != wire::MessageType::kHello) {
    fatal(s, wire::WireErrorCode::kInvalidArgument, "hello",
          std::string("expected Hello, got ") + wire::to_string(type), wire::ByeReason::kProtocolError);
    return;
  }
  switch (type) {
    case wire::MessageType::kHello:
      if (s->state != Session::State::kHandshake) {
        violation(s, wire::WireErrorCode::kInvalidArgument, "hello", "Hello after the handshake");
        return;
      }
      on_hello(s, std::get<wire::Hello>(m));
      return;
    case wire::MessageType::kPing: {
      const auto now = std::chrono::system_clock::now().time_since_epoch();
      send(s, wire::Pong{std::get<wire::Ping>(m).client_time_us,
                         uint64_t(std::chrono::duration_cast<std::chrono::microseconds>(now).count())});
      return;
    }
    case wire::MessageType::kBye: close(s, "client said bye: " + std::get<wire::Bye>(m).text); return;
    case wire::MessageType::kSubscribe: on_subscribe(s, std::get<wire::Subscribe>(m)); return;
    case wire::MessageType::kUnsubscribe: on_unsubscribe(s, std::get<wire::Unsubscribe>(m)); return;
    case wire::MessageType::kDeform: on_deform(s, std::get<wire::Deform>(m)); return;
    case wire::MessageType::kStampImageRequest:
      on_stamp_image(s, std::get<wire::StampImageRequest>(m));
      return;
    case wire::MessageType::kError:
      log_event("client_error",
                {{"client", std::to_string(s->id)}, {"text", std::get<wire::ErrorMsg>(m).text}});
      return;
    case wire::MessageType::kPong: return;
    case wire::MessageType::kStatsRequest:
      send(s, stats_message(std::get<wire::StatsRequest>(m).request_id));
      return;
    default:
      violation(s, wire::WireErrorCode::kUnknownType, "type",
                std::string(wire::to_string(type)) + " is a server-to-client message");
      return;
  }
}

void Server::on_hello(const SessionPtr& s, const wire::Hello& h) {
  if (h.version_major != wire::kProtocolMajor) {
    log_event("reject", {{"client", std::to_string(s->id)},
                         {"reason", "version"},
                         {"peer_major", std::to_string(h.version_major)}});
    ++stats_.violations;
    send(s, wire::version_mismatch(h.version_major, h.version_minor));
    send(s, wire::Bye{wire::ByeReason::kVersionMismatch, "protocol major version mismatch"});
    close(s, "version mismatch");
    return;
  }
  wire::Role granted = h.requested_role;
  switch (check_access(access_, h.access_token)) {
    case Access::kAsRequested: break;
    case Access::kSpectator: granted = wire::Role::kSpectator; break;
    case Access::kDenied:
      fatal(s, wire::WireErrorCode::kUnauthorized, "hello.access_token",
            h.access_token ? "wrong access token" : "this server requires an access token",
            wire::ByeReason::kKicked);
      return;
  }
  s->role = granted;
  s->editor = editor_role(granted);
  s->name = h.client_name;
  s->state = Session::State::kReady;
  s->timer.cancel();
  arm_idle(s);
  wire::Welcome w;
  w.client_id = s->id;
  w.granted_role = granted;
  w.world = terrain_.world().params();
  w.global_sequence = terrain_.last_seq();
  w.tick_rate_hz = uint16_t(config_.tick_hz);
  w.limits.max_frame_bytes = config_.max_frame_bytes;
  w.limits.max_subscribed_tiles = config_.max_subscriptions;
  w.limits.max_pending_deforms = config_.max_pending_deforms;
  w.limits.max_deforms_per_second = uint32_t(config_.deforms_per_second);
  send(s, w);
  log_event("hello",
            {{"client", std::to_string(s->id)}, {"name", s->name}, {"role", wire::to_string(granted)}});
}

bool Server::valid_tile(const TileCoord& c) const {
  const WorldParams& p = terrain_.world().params();
  if (c.layer == Layer::kCoarse) return c.mip < p.mip_count() && p.tile_range(c.mip).contains(c.tx, c.ty);
  return c.mip == 0 && tiles_overlapping(p.detail_sample_rect()).contains(c.tx, c.ty);
}

void Server::on_subscribe(const SessionPtr& s, const wire::Subscribe& sub) {
  for (const wire::SubscribeEntry& e : sub.entries) {
    if (!valid_tile(e.tile)) {
      violation(s, wire::WireErrorCode::kOutOfWorld, "subscribe.tile",
                "tile " + to_string(e.tile) + " is not in the world");
      continue;
    }
    if (!s->subs.count(e.tile) && s->subs.size() >= config_.max_subscriptions) {
      violation(s, wire::WireErrorCode::kOversize, "subscribe.entries",
                "subscription cap of " + std::to_string(config_.max_subscriptions) + " tiles reached");
      return;
    }
    const uint64_t current = terrain_.world().tile_state(e.tile).version;
    // A client that already holds the current version (the initial terrain's 0 included)
    // resumes without a transfer; otherwise the whole tile goes.
    s->subs[e.tile] = e.held ? e.held_version : kNeedsRegion;
    if (!e.held || e.held_version != current) send_region(s, e.tile);
  }
}

void Server::on_unsubscribe(const SessionPtr& s, const wire::Unsubscribe& u) {
  for (const TileCoord& c : u.tiles) s->subs.erase(c);
}

void Server::on_deform(const SessionPtr& s, const wire::Deform& d) {
  auto reject = [&](wire::WireErrorCode code, const std::string& field, const std::string& why) {
    ++stats_.deforms_rejected;
    ++stats_.violations;
    ++s->violations;
    wire::DeformAck ack;
    ack.client_seq = d.client_seq;
    ack.accepted = false;
    ack.reject_code = code;
    ack.field = field.substr(0, wire::kMaxFieldNameBytes);
    send(s, ack);
    log_event("deform_rejected", {{"client", std::to_string(s->id)},
                                  {"client_seq", std::to_string(d.client_seq)},
                                  {"code", wire::to_string(code)},
                                  {"field", field},
                                  {"why", why}});
  };
  if (!s->editor) {
    reject(wire::WireErrorCode::kUnauthorized, "role", "viewers cannot deform");
    return;
  }
  if (!storage_.writable()) {
    // Not the client's fault: refused, not counted as a violation.
    wire::DeformAck ack;
    ack.client_seq = d.client_seq;
    ack.accepted = false;
    ack.reject_code = wire::WireErrorCode::kIo;
    ack.field = "storage.unavailable";
    ++stats_.deforms_rejected;
    send(s, ack);
    return;
  }
  const auto now = Clock::now();
  s->tokens =
      std::min(config_.deform_burst, s->tokens + std::chrono::duration<double>(now - s->refill).count() *
                                                     config_.deforms_per_second);
  s->refill = now;
  if (s->tokens < 1.0) {
    reject(wire::WireErrorCode::kRateLimited, "deform", "rate limit exceeded");
    return;
  }
  if (s->unacked_deforms >= config_.max_pending_deforms) {
    reject(wire::WireErrorCode::kTooManyPending, "deform", "too many unacknowledged deforms");
    return;
  }
  if (const Status st = terrain_.check(d.stamp); !st.ok()) {
    reject(wire::to_wire(st.error().code), st.error().field, st.error().describe());
    return;
  }
  s->tokens -= 1.0;
  ++s->unacked_deforms;
  pending_.push_back({s, s->id, d.client_seq, d.stamp});
}

void Server::on_stamp_image(const SessionPtr& s, const wire::StampImageRequest& r) {
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
  send(s, resp);
}

void Server::send(const SessionPtr& s, const wire::Message& m) {
  if (s->closed) return;
  auto frame = wire::encode_frame(m, wire::kAbsoluteMaxFrameBytes);
  if (!frame) {
    log_event("encode_error", {{"client", std::to_string(s->id)}, {"error", frame.error().describe()}});
    return;
  }
  send_frame(s, std::move(*frame));
}

void Server::send_frame(const SessionPtr& s, std::vector<uint8_t> frame) {
  if (s->closed) return;
  s->queued_bytes += frame.size();
  s->out.push_back(std::move(frame));
  if (s->queued_bytes > config_.max_queue_bytes && s->state != Session::State::kClosing) {
    // A client that does not read must not hold the server's memory: drop it.
    log_event("drop", {{"client", std::to_string(s->id)},
                       {"reason", "send queue over " + std::to_string(config_.max_queue_bytes) + " bytes"}});
    s->out.clear();
    s->queued_bytes = 0;
    close(s, "send queue full (client not reading)");
    finish_close(s);
    return;
  }
  if (!in_tick_) flush(s);
}

void Server::flush(const SessionPtr& s) {
  if (s->writing || s->out.empty() || s->closed) return;
  s->writing = true;
  // The front frames, gathered (writev): the deque keeps them in place until written.
  constexpr size_t kMaxGatherBuffers = 64;
  std::vector<asio::const_buffer> buffers;
  const size_t count = std::min(s->out.size(), kMaxGatherBuffers);
  buffers.reserve(count);
  for (size_t i = 0; i < count; ++i) buffers.push_back(asio::buffer(s->out[i]));
  asio::async_write(s->socket, buffers, [this, s, count](const asio::error_code& ec, size_t n) {
    s->writing = false;
    if (s->closed) return;
    if (ec) {
      close(s, "write error: " + ec.message());
      finish_close(s);
      return;
    }
    stats_.bytes_out += n;
    for (size_t i = 0; i < count; ++i) {
      s->queued_bytes -= s->out.front().size();
      s->out.pop_front();
    }
    if (s->out.empty() && s->state == Session::State::kClosing) {
      finish_close(s);
      return;
    }
    flush(s);
  });
}

void Server::violation(const SessionPtr& s, wire::WireErrorCode code, const std::string& field,
                       const std::string& text) {
  ++stats_.violations;
  ++s->violations;
  log_event(
      "violation",
      {{"client", std::to_string(s->id)}, {"code", wire::to_string(code)}, {"field", field}, {"text", text}});
  send(s, wire::ErrorMsg{code, field.substr(0, wire::kMaxFieldNameBytes),
                         text.substr(0, wire::kMaxErrorTextBytes)});
}

void Server::fatal(const SessionPtr& s, wire::WireErrorCode code, const std::string& field,
                   const std::string& text, wire::ByeReason reason) {
  violation(s, code, field, text);
  send(s, wire::Bye{reason, text.substr(0, wire::kMaxErrorTextBytes)});
  close(s, text);
}

// Stops reading; the session closes when its queue has drained (or after a short linger).
void Server::close(const SessionPtr& s, const std::string& reason) {
  if (s->closed || s->state == Session::State::kClosing) return;
  s->state = Session::State::kClosing;
  s->timer.cancel();
  ++stats_.disconnects;
  log_event("disconnect", {{"client", std::to_string(s->id)}, {"reason", reason}});
  // Its queued deforms stay queued: they were validated and may already be in this tick.
  if (s->out.empty() && !s->writing) {
    finish_close(s);
    return;
  }
  s->linger.expires_after(std::chrono::seconds(2));
  std::weak_ptr<Session> weak = s;
  s->linger.async_wait([this, weak](const asio::error_code& e) {
    auto sp = weak.lock();
    if (!e && sp) finish_close(sp);
  });
}

void Server::finish_close(const SessionPtr& s) {
  if (s->closed) return;
  s->closed = true;
  s->state = Session::State::kClosing;
  asio::error_code ec;
  s->socket.shutdown(tcp::socket::shutdown_both, ec);
  s->socket.close(ec);
  s->timer.cancel();
  s->linger.cancel();
  // Deferred: finish_close can run inside a loop over sessions_ (a send that overflowed).
  asio::post(io_, [this, id = s->id] { sessions_.erase(id); });
}

void Server::schedule_tick() {
  const auto period =
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / config_.tick_hz));
  next_tick_ += period;
  const auto now = Clock::now();
  if (next_tick_ < now - period) next_tick_ = now;  // after a long stall, do not burst
  tick_timer_.expires_at(next_tick_);
  tick_timer_.async_wait([this](const asio::error_code& e) {
    if (e || failed_) return;
    tick();
    if (!stopping_) schedule_tick();
  });
}

void Server::send_region(const SessionPtr& s, const TileCoord& c, std::optional<RectI> part, uint64_t base) {
  const World& w = terrain_.world();
  const RectI rect = part.value_or(RectI{0, 0, kTileSize, kTileSize});
  Result<std::vector<uint8_t>> payload = [&]() -> Result<std::vector<uint8_t>> {
    const int32_t rw = int32_t(rect.width()), rh = int32_t(rect.height());
    if (c.layer == Layer::kCoarse) {
      const std::span<const uint16_t> tile = w.coarse_tile(c.mip, c.tx, c.ty);
      if (!part) return encode_region(RegionEncoding::kFast, tile, kTileSize, kTileSize);
      const std::vector<uint16_t> samples = copy_tile_rect(tile, rect);
      return encode_region(RegionEncoding::kFast, std::span<const uint16_t>(samples), rw, rh);
    }
    const std::vector<int8_t> samples = copy_tile_rect(w.detail_tile(c.tx, c.ty), rect);
    return encode_region(RegionEncoding::kFast, std::span<const int8_t>(samples), rw, rh);
  }();
  if (!payload) {
    log_event("encode_error", {{"tile", to_string(c)}, {"error", payload.error().describe()}});
    return;
  }
  wire::RegionUpdate header;
  header.tile = c;
  header.rect = rect;
  header.patch = part.has_value();
  header.base_version = part ? base : 0;
  header.new_version = w.tile_state(c).version;
  header.encoding = wire::RegionEncoding::kCodec;
  auto chunks = wire::chunk_region(header, *payload);
  if (!chunks) {
    log_event("encode_error", {{"tile", to_string(c)}, {"error", chunks.error().describe()}});
    return;
  }
  for (const wire::RegionUpdate& r : *chunks) send(s, r);
  s->subs[c] = header.new_version;
  ++stats_.regions_sent;
  if (part) ++stats_.partial_regions_sent;
}

void Server::send_hashes(const SessionPtr& s) {
  wire::TileHashes msg;
  for (const auto& [c, held] : s->subs) {
    const TileState st = terrain_.world().tile_state(c);
    msg.entries.push_back({c, st.version, st.hash});
    if (msg.entries.size() == wire::kMaxTileHashEntries) {
      send(s, msg);
      msg.entries.clear();
    }
  }
  if (!msg.entries.empty()) send(s, msg);
}

void Server::tick() {
  const auto t0 = Clock::now();
  ++tick_;
  in_tick_ = true;
  struct FlushAtEnd {  // on every way out of the tick, shutdown included
    Server* server;
    ~FlushAtEnd() {
      server->in_tick_ = false;
      // A copy: a failed write can close a session, which erases it (posted, but be safe).
      std::vector<SessionPtr> all;
      for (auto& [id, s] : server->sessions_) all.push_back(s);
      for (const SessionPtr& s : all) server->flush(s);
    }
  } flush_at_end{this};
  std::vector<PendingDeform> batch = std::move(pending_);
  pending_.clear();

  if (!storage_.writable()) try_resume_storage(t0);
  if (!batch.empty() && !storage_.writable()) {
    refuse_batch(batch);
    batch.clear();
  }
  if (!batch.empty()) {
    // 1. Sequence and log the whole tick, then one fsync: the durability point.
    uint64_t seq = terrain_.last_seq();
    for (const PendingDeform& p : batch) {
      const Status st = storage_.append({++seq, tick_, p.client_id, p.stamp});
      if (!st.ok()) {  // a broken invariant (sequence or tick), not the disk
        log_event("fatal", {{"error", st.error().describe()}});
        failed_ = true;
        shutdown("log append failed");
        return;
      }
    }
    if (const Status st = storage_.sync(); !st.ok()) {
      // A full disk or an I/O error: nothing of this tick is durable (the writer cut the
      // file back), so nothing of it is applied or acknowledged. The server keeps serving
      // reads and hashes, refuses edits, and retries the log with a growing interval.
      log_event("storage_unavailable",
                {{"error", st.error().describe()}, {"refused", std::to_string(batch.size())}});
      ++stats_.storage_failures;
      resume_backoff_s_ = kResumeBackoffMinS;
      next_resume_try_ =
          t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(resume_backoff_s_));
      refuse_batch(batch);
      batch.clear();
    }
  }
  if (!batch.empty()) {
    // 2. Apply, acknowledge, stream events; note tiles a client cannot reproduce itself.
    // Per (client, tile): the version the client held before this tick's first change it could
    // not follow (none: unknown) and the union of the samples changed since (tile-local).
    struct NeededRegion {
      std::optional<uint64_t> base;
      RectI rect;
    };
    std::map<std::pair<uint32_t, TileCoord>, NeededRegion> needs_region;
    for (const PendingDeform& p : batch) {
      const uint64_t s_seq = terrain_.last_seq() + 1;
      auto applied = terrain_.apply(p.stamp, s_seq, p.client_id);
      for (const Error& e : terrain_.take_backend_failures())
        log_event("backend_error",
                  {{"seq", std::to_string(s_seq)}, {"error", e.describe()}, {"fallback", "cpu"}});
      if (!applied)
        log_event("apply_error", {{"seq", std::to_string(s_seq)}, {"error", applied.error().describe()}});
      ++stats_.deforms_accepted;
      if (auto sender = p.session.lock()) {
        --sender->unacked_deforms;
        wire::DeformAck ack;
        ack.client_seq = p.client_seq;
        ack.accepted = true;
        ack.global_seq = s_seq;
        send(sender, ack);
      }
      if (!applied) continue;
      const AppliedStamp& a = *applied;
      // One encoding of the event for every client it goes to.
      wire::DeformEvent ev;
      ev.global_seq = a.seq;
      ev.origin_client_id = a.client_id;
      ev.stamp = a.stamp;
      ev.base_versions = a.base_versions;
      if (ev.base_versions.size() > wire::kMaxEventTiles) ev.base_versions.resize(0);  // regions only
      auto event_frame = wire::encode_frame(ev, wire::kAbsoluteMaxFrameBytes);
      if (!event_frame)  // no event then: every client gets the changed tiles as regions
        log_event("encode_error",
                  {{"seq", std::to_string(a.seq)}, {"error", event_frame.error().describe()}});
      for (auto& [id, s] : sessions_) {
        if (s->state != Session::State::kReady) continue;
        bool touches = false;
        for (const wire::TileVersion& bv : a.base_versions) touches = touches || s->subs.count(bv.tile);
        if (!touches) continue;
        if (event_frame) {
          send_frame(s, *event_frame);
          ++stats_.events_sent;
        }
        // The client's rule (client/net/confirmed_store): it applies the stamp to the mip-0
        // tiles of the stamp's layer it holds when each is at the listed base version (and,
        // for a footprint, it holds every listed one). Mip > 0 tiles always come as regions.
        bool can_apply = event_frame && !ev.base_versions.empty();
        for (const wire::TileVersion& bv : a.base_versions) {
          if (bv.tile.mip != 0 || bv.tile.layer != a.stamp.layer) continue;
          const auto it = s->subs.find(bv.tile);
          if (it == s->subs.end()) {
            if (a.stamp.kind == StampKind::kFootprint) can_apply = false;
            continue;
          }
          if (it->second != bv.version) can_apply = false;
        }
        for (const TileChange& c : a.changes) {
          const auto it = s->subs.find(c.coord);
          if (it == s->subs.end()) continue;
          const bool derived = c.coord.mip != 0 || c.coord.layer != a.stamp.layer;
          if (can_apply && !derived) {
            it->second = c.new_version;
          } else {
            NeededRegion& need = needs_region[{id, c.coord}];
            if (it->second != kNeedsRegion) need.base = it->second;
            need.rect = need.rect.unite(c.rect);
            it->second = kNeedsRegion;
          }
        }
      }
    }
    // 3. Regions for what clients could not apply, at the tick's final version: only the
    // changed samples where the client holds a known version of the rest of the tile (a stamp
    // changes a few hundred samples of a mip tile, not 65536), else the whole tile.
    for (const auto& [key, need] : needs_region) {
      const auto& [id, c] = key;
      const auto it = sessions_.find(id);
      if (it == sessions_.end() || !it->second->subs.count(c)) continue;
      const bool patch = need.base && need.rect.area() * 4 <= kTileSamples;
      send_region(it->second, c, patch ? std::optional<RectI>(need.rect) : std::nullopt,
                  need.base.value_or(0));
    }
  }
  if (config_.hashes_every_ticks > 0 && tick_ % config_.hashes_every_ticks == 0) {
    for (auto& [id, s] : sessions_) {
      if (s->state == Session::State::kReady && !s->subs.empty()) send_hashes(s);
    }
  }
  maybe_snapshot(false);
  const double ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  tick_ms_.push_back(ms);
  if (ms > 1000.0 / config_.tick_hz) {
    ++stats_.tick_overruns;
    log_event("tick_overrun", {{"tick", std::to_string(tick_)},
                               {"ms", std::to_string(ms)},
                               {"stamps", std::to_string(batch.size())}});
  }
}

void Server::refuse_batch(const std::vector<PendingDeform>& batch) {
  for (const PendingDeform& p : batch) {
    ++stats_.deforms_rejected;
    auto sender = p.session.lock();
    if (!sender) continue;
    --sender->unacked_deforms;
    wire::DeformAck ack;
    ack.client_seq = p.client_seq;
    ack.accepted = false;
    ack.reject_code = wire::WireErrorCode::kIo;
    ack.field = "storage.unavailable";
    send(sender, ack);
  }
}

void Server::try_resume_storage(Clock::time_point now) {
  if (now < next_resume_try_) return;
  if (const Status st = storage_.resume(terrain_.last_seq()); !st.ok()) {
    resume_backoff_s_ = std::min(resume_backoff_s_ * 2.0, kResumeBackoffMaxS);
    next_resume_try_ =
        now + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(resume_backoff_s_));
    log_event("storage_retry",
              {{"error", st.error().describe()}, {"next_in_s", std::to_string(resume_backoff_s_)}});
    return;
  }
  log_event("storage_resumed", {{"seq", std::to_string(terrain_.last_seq())}});
}

void Server::maybe_snapshot(bool force) {
  if (!storage_.writable()) return;  // the log must be writable to start the next segment
  if (!force && Clock::now() < snapshot_retry_after_) return;
  const uint64_t since = terrain_.last_seq() - storage_.last_snapshot_seq();
  const double age = std::chrono::duration<double>(Clock::now() - last_snapshot_time_).count();
  const bool due = force || (config_.snapshot_every_stamps > 0 && since >= config_.snapshot_every_stamps) ||
                   (config_.snapshot_interval_s > 0 && age >= config_.snapshot_interval_s && since > 0);
  // Nothing new since the last snapshot (or since the initial terrain, which segment 0's
  // header already describes): a snapshot would add nothing.
  if (!due || since == 0 || terrain_.last_seq() == 0) return;
  const auto t0 = Clock::now();
  auto path = storage_.snapshot(terrain_, tick_);
  last_snapshot_time_ = Clock::now();
  if (!path) {
    // Nothing is left behind (write_snapshot removes its partial folder); retrying at once
    // on a full disk would only churn, so the interval grows.
    snapshot_backoff_s_ = snapshot_backoff_s_ == 0
                              ? kSnapshotBackoffMinS
                              : std::min(snapshot_backoff_s_ * 2.0, kSnapshotBackoffMaxS);
    snapshot_retry_after_ = last_snapshot_time_ + std::chrono::duration_cast<Clock::duration>(
                                                      std::chrono::duration<double>(snapshot_backoff_s_));
    log_event("snapshot_error",
              {{"error", path.error().describe()}, {"retry_in_s", std::to_string(snapshot_backoff_s_)}});
    return;
  }
  snapshot_backoff_s_ = 0;
  log_event("snapshot",
            {{"path", *path},
             {"seq", std::to_string(terrain_.last_seq())},
             {"ms", std::to_string(std::chrono::duration<double, std::milli>(Clock::now() - t0).count())}});
}

void Server::report_stats() {
  std::vector<double> t = std::move(tick_ms_);
  tick_ms_.clear();
  std::sort(t.begin(), t.end());
  last_p50_ms_ = percentile(t, 0.5);
  last_p99_ms_ = percentile(t, 0.99);
  uint64_t max_queue = 0;
  for (const auto& [id, s] : sessions_) max_queue = std::max(max_queue, s->queued_bytes);
  log_event("stats", {{"clients", std::to_string(sessions_.size())},
                      {"seq", std::to_string(terrain_.last_seq())},
                      {"deforms_accepted", std::to_string(stats_.deforms_accepted)},
                      {"deforms_rejected", std::to_string(stats_.deforms_rejected)},
                      {"violations", std::to_string(stats_.violations)},
                      {"bytes_in", std::to_string(stats_.bytes_in)},
                      {"bytes_out", std::to_string(stats_.bytes_out)},
                      {"regions_sent", std::to_string(stats_.regions_sent)},
                      {"partial_regions_sent", std::to_string(stats_.partial_regions_sent)},
                      {"max_queue_bytes", std::to_string(max_queue)},
                      {"tick_p50_ms", std::to_string(last_p50_ms_)},
                      {"tick_p99_ms", std::to_string(last_p99_ms_)},
                      {"storage", storage_.writable() ? "ok" : "refusing edits"},
                      {"storage_failures", std::to_string(stats_.storage_failures)}});
  if (stopping_) return;
  stats_timer_.expires_after(
      std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(config_.stats_interval_s)));
  stats_timer_.async_wait([this](const asio::error_code& e) {
    if (!e) report_stats();
  });
}

wire::Stats Server::stats_message(uint32_t request_id) const {
  wire::Stats st;
  st.request_id = request_id;
  st.clients = uint32_t(sessions_.size());
  st.global_sequence = terrain_.last_seq();
  st.deforms_accepted = stats_.deforms_accepted;
  st.deforms_rejected = stats_.deforms_rejected;
  st.violations = stats_.violations;
  st.bytes_in = stats_.bytes_in;
  st.bytes_out = stats_.bytes_out;
  st.tick_overruns = stats_.tick_overruns;
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
  st.uptime_ms =
      uint64_t(std::chrono::duration_cast<std::chrono::milliseconds>(Clock::now() - started_).count());
  return st;
}

void Server::shutdown(const std::string& reason) {
  if (stopping_) return;
  stopping_ = true;
  log_event("shutdown", {{"reason", reason}});
  asio::error_code ec;
  acceptor_.close(ec);
  tick_timer_.cancel();
  stats_timer_.cancel();
  signals_.cancel();
  reload_signal_.cancel();
  if (!failed_) {
    // Stamps still queued were never acknowledged: dropping them loses nothing promised.
    pending_.clear();
    if (storage_.writable()) {
      if (const Status st = storage_.sync(); !st.ok()) log_event("fatal", {{"error", st.error().describe()}});
    }
    maybe_snapshot(true);
  }
  std::vector<SessionPtr> all;
  for (auto& [id, s] : sessions_) all.push_back(s);
  for (const SessionPtr& s : all) {
    send(s, wire::Bye{wire::ByeReason::kShutdown, "server shutting down: " + reason});
    close(s, "server shutdown");
  }
}

}  // namespace loam::server
