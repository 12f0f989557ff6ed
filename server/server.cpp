#include "server/server.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <vector>

#include "protocol/hex64.h"
#include "server/event_log.h"
#include "transport/tls_context.h"

namespace loam::server {

using asio::ip::tcp;
using Clock = std::chrono::steady_clock;

namespace {

Clock::duration after(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

// The shell reads the clocks and gives the core their time (core_time.h).
CoreTime core_time(Clock::time_point t) {
  return CoreTime(std::chrono::duration_cast<CoreDuration>(t.time_since_epoch()));
}
Clock::time_point steady_time(CoreTime t) {
  return Clock::time_point(std::chrono::duration_cast<Clock::duration>(t.time_since_epoch()));
}
UnixMicros wall_now() {
  return UnixMicros(std::chrono::duration_cast<std::chrono::microseconds>(
                        std::chrono::system_clock::now().time_since_epoch())
                        .count());
}
double ms_between(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

}  // namespace

struct Server::Connection {
  Connection(tcp::socket s, std::shared_ptr<asio::ssl::context> tls, asio::io_context& io, uint32_t max_frame)
      : stream(std::move(s), std::move(tls)), assembler(max_frame), timer(io), linger(io), read_pause(io) {}

  transport::Stream stream;
  wire::FrameAssembler assembler;
  asio::steady_timer timer;       // handshake, then idle timeout
  asio::steady_timer linger;      // bounds the time a closing connection may take to flush
  asio::steady_timer read_pause;  // a client over its request rate is read again when it ends
  std::array<uint8_t, 64 * 1024> read_buffer{};
  std::deque<FramePtr> out;
  uint64_t queued_bytes = 0;
  bool writing = false;
  bool secured = false;  // the TLS handshake is done (at once without TLS): writes may start
  bool closing = false;  // no more reads; closes once flushed
  bool closed = false;
  ClientId id = 0;
};

Server::Server(asio::io_context& io, ServerConfig config, OpenedStorage opened)
    : io_(io),
      config_(config),
      core_(std::move(config), std::move(opened), core_time(Clock::now()), &counters_),
      acceptor_(io),
      metrics_(io,
               [this] {
                 counters_.max_queue_bytes = 0;
                 for (const auto& [id, c] : connections_)
                   counters_.max_queue_bytes = std::max(counters_.max_queue_bytes, c->queued_bytes);
                 return prometheus_text(core_.metrics());
               }),
      tick_timer_(io),
      stats_timer_(io),
      signals_(io, SIGINT, SIGTERM),
      reload_signal_(io, SIGHUP) {}

Server::~Server() = default;

Status Server::start() {
  asio::error_code ec;
  const auto address = asio::ip::make_address(config_.bind_address, ec);
  if (ec) return make_error(ErrorCode::kInvalidArgument, "bind_address", ec.message());
  std::string tls_fingerprint;
  if (!config_.tls_cert_file.empty() || !config_.tls_key_file.empty()) {
    if (config_.tls_cert_file.empty() || config_.tls_key_file.empty())
      return make_error(ErrorCode::kInvalidArgument, "tls", "--tls-cert and --tls-key go together");
    auto ctx = transport::make_server_context(config_.tls_cert_file, config_.tls_key_file);
    if (!ctx) return ctx.error();
    tls_ = *ctx;
    auto f = transport::certificate_fingerprint(config_.tls_cert_file);
    if (!f) return f.error();
    tls_fingerprint = transport::fingerprint_text(*f);
  }
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
  // Before the port file: whoever waits for it may count on everything being up.
  if (!config_.metrics_bind.empty()) {
    LOAM_TRY(metrics_.start(config_.metrics_bind));
    log_event("metrics_listening",
              {{"bind", config_.metrics_bind}, {"port", std::to_string(metrics_.port())}});
  }
  // What a client pins with --tls-fingerprint (a self-signed certificate needs no CA).
  if (tls_) log_event("tls", {{"certificate", config_.tls_cert_file}, {"sha256", tls_fingerprint}});
  signals_.async_wait([this](const asio::error_code& e, int sig) {
    if (!e) shutdown(sig == SIGINT ? "SIGINT" : "SIGTERM");
  });
  wait_for_reload();
  const AccessTokens& access = core_.access();
  log_event("listening", {{"address", config_.bind_address},
                          {"port", std::to_string(port_)},
                          {"tick_hz", std::to_string(config_.tick_hz)},
                          {"last_seq", std::to_string(core_.terrain().last_seq())},
                          {"world_hash", hex64(core_.terrain().world().world_hash())},
                          {"world_tiles", std::to_string(core_.terrain().world().params().tiles_x) + "x" +
                                              std::to_string(core_.terrain().world().params().tiles_y)},
                          {"base", core_.terrain().world().base().describe()},
                          {"access", access.required() ? "tokens" : "open"},
                          {"editor_tokens", std::to_string(access.editors.size())},
                          {"viewer_tokens", std::to_string(access.viewers.size())},
                          {"tls", tls_ ? "on" : "off"},
                          {"client_bytes_per_second", std::to_string(config_.client_bytes_per_second)}});
  // The port file last: whoever waits for it may count on the listening line being logged.
  if (!config_.port_file.empty()) {
    const std::string tmp = config_.port_file + ".tmp";
    {
      std::ofstream f(tmp);
      f << port_ << "\n";
      if (!f) return make_error(ErrorCode::kIo, config_.port_file, "cannot write the port file");
    }
    std::rename(tmp.c_str(), config_.port_file.c_str());
  }
  const bool loopback = address.is_loopback();
  if (!access.required() && !loopback) {
    log_event("warning", {{"what",
                           "no tokens configured on a non-loopback address: anyone who reaches "
                           "this port can edit (docs/configuration.md, --tokens-file)"}});
  }
  if (access.required() && !tls_ && !loopback) {
    log_event("warning", {{"what",
                           "tokens configured without TLS on a non-loopback address: they cross the "
                           "network in clear (docs/configuration.md, --tls-cert)"}});
  }
  core_.warn_if_tokens_file_exposed();
  deliver();
  accept();
  next_tick_ = Clock::now();
  schedule_tick();
  schedule_stats();
  return {};
}

void Server::wait_for_reload() {
  reload_signal_.async_wait([this](const asio::error_code& e, int) {
    if (e) return;  // cancelled at shutdown
    core_.reload_tokens();
    deliver();
    wait_for_reload();
  });
}

void Server::schedule_stats() {
  if (config_.stats_interval_s <= 0 || stopping_) return;
  stats_timer_.expires_after(after(config_.stats_interval_s));
  stats_timer_.async_wait([this](const asio::error_code& e) {
    if (e) return;
    counters_.max_queue_bytes = 0;
    for (const auto& [id, c] : connections_)
      counters_.max_queue_bytes = std::max(counters_.max_queue_bytes, c->queued_bytes);
    flush_suppressed_log_lines();  // before the stats line, as the period's summary
    core_.report_stats(core_time(Clock::now()));
    deliver();
    schedule_stats();
  });
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
  auto c = std::make_shared<Connection>(std::move(socket), tls_, io_, config_.max_frame_bytes);
  const auto remote = c->stream.socket().remote_endpoint(ec);
  const std::string peer = ec ? "?" : remote.address().to_string() + ":" + std::to_string(remote.port());
  // The TLS handshake counts as part of the protocol's: the same pool and the same timer.
  c->id = core_.connect(peer, core_time(Clock::now()));
  connections_[c->id] = c;
  arm_timer(c, config_.handshake_timeout_s, true);
  deliver();  // a refusal (server full) is queued here, to leave once the stream is secured
  c->stream.async_handshake(asio::ssl::stream_base::server, [this, c, peer](const asio::error_code& e) {
    if (c->closed) return;
    if (e) {
      ++counters_.tls_handshake_failures;
      log_event("tls_handshake_failed",
                {{"client", std::to_string(c->id)}, {"peer", peer}, {"error", e.message()}});
      finish_close(c, "TLS handshake failed: " + e.message());
      return;
    }
    c->secured = true;
    flush(c);
    if (!c->closing) read(c);
  });
}

void Server::arm_timer(const ConnectionPtr& c, double seconds, bool handshake) {
  if (seconds <= 0) return;
  c->timer.expires_after(after(seconds));
  std::weak_ptr<Connection> weak = c;
  c->timer.async_wait([this, weak, handshake](const asio::error_code& e) {
    auto cp = weak.lock();
    if (e || !cp || cp->closing) return;
    core_.timed_out(cp->id, handshake);
    deliver();
  });
}

void Server::read(const ConnectionPtr& c) {
  c->stream.async_read_some(asio::buffer(c->read_buffer), [this, c](const asio::error_code& ec, size_t n) {
    if (c->closed || c->closing) return;
    if (ec) {
      finish_close(c, ec == asio::error::eof ? "peer closed" : "read error: " + ec.message());
      return;
    }
    counters_.bytes_in += n;
    c->assembler.feed(std::span(c->read_buffer.data(), n));
    if (drain(c)) read(c);
  });
}

bool Server::drain(const ConnectionPtr& c) {
  const auto now = Clock::now();
  bool complete = false, paused = false;
  while (!c->closing) {
    // A client past its request rate (refused once, its bucket still empty) is not decoded
    // further until the bucket refills: reading stops, its socket fills, and the flood waits
    // on its own side instead of costing this thread a decode per dropped request.
    if (const auto until = core_.reads_paused_until(c->id, core_time(now))) {
      paused = true;
      c->read_pause.expires_at(steady_time(*until));
      c->read_pause.async_wait([this, weak = std::weak_ptr<Connection>(c)](const asio::error_code& e) {
        auto cp = weak.lock();
        if (e || !cp || cp->closed || cp->closing) return;
        if (drain(cp)) read(cp);
      });
      break;
    }
    auto next = c->assembler.next_message();
    if (!next) {
      core_.stream_error(c->id, next.error());
      break;
    }
    if (!next->has_value()) break;
    core_.receive(c->id, **next, core_time(now), wall_now());
    complete = true;
    deliver();
  }
  deliver();
  // A complete frame from a client in session restarts its idle timer (the handshake's runs
  // on). Bytes alone do not: a byte now and then of a frame never finished must not hold a
  // session open.
  if (complete && !c->closing && !core_.in_handshake(c->id)) arm_timer(c, config_.idle_timeout_s, false);
  return !paused && !c->closed && !c->closing;
}

void Server::write_core_log(const std::vector<CoreLogLine>& lines) {
  for (const CoreLogLine& l : lines) log_event(l.event, l.fields);
}

void Server::deliver() {
  CoreOutput out = core_.take_output();
  write_core_log(out.log);
  // Queue everything first, then write: a tick's acks, events and regions for a client leave
  // in one gathered write, one wake-up of the client instead of one each.
  std::vector<ConnectionPtr> touched;
  for (auto& [id, frame] : out.frames) {
    const auto it = connections_.find(id);
    if (it == connections_.end()) continue;
    if (touched.empty() || touched.back() != it->second) touched.push_back(it->second);
    queue(it->second, std::move(frame));
  }
  for (const ConnectionPtr& c : touched) flush(c);
  for (const auto& [id, reason] : out.closes) {
    const auto it = connections_.find(id);
    if (it != connections_.end()) close_after_flush(it->second);
  }
}

void Server::queue(const ConnectionPtr& c, FramePtr frame) {
  if (c->closed) return;
  c->queued_bytes += frame->size();
  c->out.push_back(std::move(frame));
  if (c->queued_bytes > config_.max_queue_bytes && !c->closing) {
    // A client that does not read must not hold the server's memory: drop it.
    log_event("drop", {{"client", std::to_string(c->id)},
                       {"reason", "send queue over " + std::to_string(config_.max_queue_bytes) + " bytes"}});
    c->out.clear();
    c->queued_bytes = 0;
    core_.disconnected(c->id, "send queue full (client not reading)");
    write_core_log(core_.take_log());
    finish_close(c, "");
  }
}

void Server::flush(const ConnectionPtr& c) {
  if (c->writing || c->out.empty() || c->closed || !c->secured) return;
  c->writing = true;
  // The front frames, gathered (writev): the deque keeps them alive until written.
  constexpr size_t kMaxGatherBuffers = 64;
  std::vector<asio::const_buffer> buffers;
  const size_t count = std::min(c->out.size(), kMaxGatherBuffers);
  buffers.reserve(count);
  for (size_t i = 0; i < count; ++i) buffers.push_back(asio::buffer(*c->out[i]));
  c->stream.async_write(buffers, [this, c, count](const asio::error_code& ec, size_t n) {
    c->writing = false;
    if (c->closed) return;
    if (ec) {
      finish_close(c, "write error: " + ec.message());
      return;
    }
    counters_.bytes_out += n;
    for (size_t i = 0; i < count; ++i) {
      c->queued_bytes -= c->out.front()->size();
      c->out.pop_front();
    }
    if (c->out.empty() && c->closing) {
      finish_close(c, "");
      return;
    }
    flush(c);
  });
}

// Stops reading; the connection closes when its queue has drained (or after a short linger).
void Server::close_after_flush(const ConnectionPtr& c) {
  if (c->closed || c->closing) return;
  c->closing = true;
  c->timer.cancel();
  if (c->out.empty() && !c->writing) {
    finish_close(c, "");
    return;
  }
  c->linger.expires_after(std::chrono::seconds(2));
  std::weak_ptr<Connection> weak = c;
  c->linger.async_wait([this, weak](const asio::error_code& e) {
    auto cp = weak.lock();
    if (!e && cp) finish_close(cp, "");
  });
}

// `reason` non-empty: the peer went away; the core forgets the client (a no-op when the core
// closed it itself).
void Server::finish_close(const ConnectionPtr& c, const std::string& reason) {
  if (c->closed) return;
  c->closed = true;
  c->closing = true;
  if (!reason.empty()) {
    core_.disconnected(c->id, reason);
    write_core_log(core_.take_log());
  }
  c->stream.close();
  c->timer.cancel();
  c->linger.cancel();
  c->read_pause.cancel();
  // Deferred: finish_close can run inside a loop over connections_.
  asio::post(io_, [this, id = c->id] { connections_.erase(id); });
}

void Server::schedule_tick() {
  const auto period = after(1.0 / config_.tick_hz);
  next_tick_ += period;
  const auto now = Clock::now();
  if (next_tick_ < now - period) next_tick_ = now;  // after a long stall, do not burst
  tick_timer_.expires_at(next_tick_);
  tick_timer_.async_wait([this](const asio::error_code& e) {
    if (e || core_.failed()) return;
    tick();
    if (!stopping_ && !core_.failed()) schedule_tick();
  });
}

// The core's tick, its phases timed here (the core reads no clock) and its wait for the apply
// owned here: up to --apply-wait-ms from the end of the commit.
void Server::tick() {
  const auto t0 = Clock::now();
  const auto apply_wait = std::chrono::microseconds(int64_t(std::max(0.0, config_.apply_wait_ms) * 1000.0));
  ReplicationCore::TickTimes times;
  auto mark = t0;
  const auto lap = [&mark] {
    const auto t = Clock::now();
    return ms_between(std::exchange(mark, t), t);
  };
  Clock::time_point deadline = t0 + apply_wait;
  double log_ms = 0;
  bool applied_phase = false;
  TickHooks hooks;
  hooks.unsent = [this](ClientId id) -> uint64_t {
    const auto it = connections_.find(id);
    return it == connections_.end() ? 0 : it->second->queued_bytes;
  };
  // The acks go out now (a write starts at once), before the tick applies and streams.
  hooks.acks_ready = [this] { deliver(); };
  hooks.wait_for_apply = [&deadline](ApplyWorker& w) { return w.wait_until(deadline); };
  hooks.phase_done = [&](TickPhase phase) {
    switch (phase) {
      case TickPhase::kLogged: log_ms = lap(); break;
      case TickPhase::kSynced: times.sync_ms = lap(); break;
      case TickPhase::kCommitted:
        times.commit_ms = log_ms + times.sync_ms + lap();
        deadline = mark + apply_wait;
        break;
      case TickPhase::kApplied:
        times.apply_wait_ms = lap();
        applied_phase = true;
        break;
      case TickPhase::kStreamed: times.stream_ms = lap(); break;
      case TickPhase::kPersisted: times.snapshot_ms = lap(); break;
      case TickPhase::kTrimmed: times.trim_ms = lap(); break;
    }
  };
  const bool streamed = run_tick(core_, core_time(t0), wall_now(), hooks);
  times.world_busy = applied_phase && !streamed;
  deliver();
  times.total_ms = ms_between(t0, Clock::now());
  core_.record_tick(times);
  write_core_log(core_.take_log());
  if (core_.failed()) shutdown("log append failed");
}

void Server::shutdown(const std::string& reason) {
  if (stopping_) return;
  stopping_ = true;
  asio::error_code ec;
  acceptor_.close(ec);
  metrics_.stop();
  tick_timer_.cancel();
  stats_timer_.cancel();
  signals_.cancel();
  reload_signal_.cancel();
  core_.shutdown(reason, core_time(Clock::now()), wall_now());
  deliver();
}

}  // namespace loam::server
