// The session host: accepts TCP clients (Asio, one I/O thread), runs the handshake, roles,
// subscriptions and limits, and a fixed-rate tick that sequences accepted stamps, makes them
// durable (group commit: one fsync per tick before any acknowledgement), applies them,
// acknowledges, and streams DeformEvents and RegionUpdates to subscribed clients.
//
// Every client input is untrusted: frames are decoded by protocol/wire (bounded), each
// violation answers with an Error carrying a code and is counted, and none disturbs other
// clients. A client that stops reading is dropped once its queue passes its bound.
#pragma once

#include <asio.hpp>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "protocol/wire/framing.h"
#include "protocol/wire/messages.h"
#include "server/access_tokens.h"
#include "server/server_config.h"
#include "server/storage.h"

namespace loam::server {

struct ServerStats {
  uint64_t connects = 0, disconnects = 0;
  uint64_t deforms_accepted = 0, deforms_rejected = 0;
  uint64_t violations = 0;  // every Error sent for a client's fault
  uint64_t bytes_in = 0, bytes_out = 0;
  uint64_t regions_sent = 0, partial_regions_sent = 0, events_sent = 0;
  uint64_t tick_overruns = 0;
  uint64_t storage_failures = 0;  // syncs that failed (a full disk): edits refused until resumed
};

class Server {
 public:
  Server(asio::io_context& io, ServerConfig config, OpenedStorage storage);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds, listens (writing the port file if configured) and starts the tick. Errors when the
  // address cannot be bound.
  Status start();
  uint16_t port() const { return port_; }
  // Graceful stop: stop accepting, make the log durable, write a snapshot, send Bye to every
  // client, then let the io_context run out.
  void shutdown(const std::string& reason);
  const ServerStats& stats() const { return stats_; }
  bool failed() const { return failed_; }

 private:
  struct Session;
  using SessionPtr = std::shared_ptr<Session>;
  struct PendingDeform {
    std::weak_ptr<Session> session;
    uint32_t client_id = 0;
    uint32_t client_seq = 0;
    QuantizedStamp stamp;
  };

  void accept();
  void on_accept(asio::ip::tcp::socket socket);
  void read(const SessionPtr& s);
  void on_bytes(const SessionPtr& s, size_t n);
  void handle(const SessionPtr& s, wire::Message& m);
  void on_hello(const SessionPtr& s, const wire::Hello& h);
  void on_subscribe(const SessionPtr& s, const wire::Subscribe& sub);
  void on_unsubscribe(const SessionPtr& s, const wire::Unsubscribe& u);
  void on_deform(const SessionPtr& s, const wire::Deform& d);
  void on_stamp_image(const SessionPtr& s, const wire::StampImageRequest& r);

  void send(const SessionPtr& s, const wire::Message& m);
  // Queues an encoded frame (one encoding shared by every client a DeformEvent goes to).
  void send_frame(const SessionPtr& s, std::vector<uint8_t> frame);
  // Writes the queued frames, up to kMaxGatherBuffers of them in one gathered write.
  void wait_for_reload();
  void reload_tokens();
  void warn_if_tokens_file_exposed();  // a log warning when the tokens file is group/world-readable
  void flush(const SessionPtr& s);
  void violation(const SessionPtr& s, wire::WireErrorCode code, const std::string& field,
                 const std::string& text);
  void fatal(const SessionPtr& s, wire::WireErrorCode code, const std::string& field, const std::string& text,
             wire::ByeReason reason);
  void close(const SessionPtr& s, const std::string& reason);
  void finish_close(const SessionPtr& s);
  void arm_idle(const SessionPtr& s);

  void schedule_tick();
  void tick();
  // The tile c to a client: whole, or only `part` (tile-local samples) over the `base` version
  // the client holds of the rest.
  void send_region(const SessionPtr& s, const TileCoord& c, std::optional<RectI> part = std::nullopt,
                   uint64_t base = 0);
  void send_hashes(const SessionPtr& s);
  bool valid_tile(const TileCoord& c) const;
  void maybe_snapshot(bool force);
  // Rejects deforms that could not be made durable (ack: i/o error, field storage.unavailable).
  void refuse_batch(const std::vector<PendingDeform>& batch);
  // While the log is not writable: reopen it when the back-off interval has passed.
  void try_resume_storage(std::chrono::steady_clock::time_point now);
  void report_stats();
  wire::Stats stats_message(uint32_t request_id) const;

  asio::io_context& io_;
  ServerConfig config_;
  AccessTokens access_;
  Storage storage_;
  TerrainState terrain_;
  asio::ip::tcp::acceptor acceptor_;
  asio::steady_timer tick_timer_;
  asio::steady_timer stats_timer_;
  asio::signal_set signals_;
  // SIGHUP: the tokens are read again (a rotated secret); connected clients keep their roles.
  asio::signal_set reload_signal_;
  std::chrono::steady_clock::time_point next_tick_;
  std::chrono::steady_clock::time_point last_snapshot_time_;
  // A failed snapshot is retried after a growing interval (a full disk).
  static constexpr double kSnapshotBackoffMinS = 5.0, kSnapshotBackoffMaxS = 300.0;
  double snapshot_backoff_s_ = 0;
  std::chrono::steady_clock::time_point snapshot_retry_after_{};
  // A failed log sync refuses edits; reopening is retried after a growing interval.
  static constexpr double kResumeBackoffMinS = 0.25, kResumeBackoffMaxS = 10.0;
  double resume_backoff_s_ = kResumeBackoffMinS;
  std::chrono::steady_clock::time_point next_resume_try_{};
  std::map<uint32_t, SessionPtr> sessions_;
  std::vector<PendingDeform> pending_;
  uint32_t next_client_id_ = 1;
  uint64_t tick_ = 0;
  // While a tick runs, sends only queue: the tick's acks, events and regions for a client
  // leave in one gathered write at its end, one wake-up of the client instead of one each.
  bool in_tick_ = false;
  uint16_t port_ = 0;
  bool stopping_ = false;
  bool failed_ = false;
  ServerStats stats_;
  std::vector<double> tick_ms_;               // since the last stats line
  double last_p50_ms_ = 0, last_p99_ms_ = 0;  // of the last stats period
  std::chrono::steady_clock::time_point started_ = std::chrono::steady_clock::now();
};

}  // namespace loam::server
