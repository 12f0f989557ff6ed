// The session host's transport: a thin Asio shell around the replication core
// (server/replication/replication_core.h). It accepts TCP clients (TLS with --tls-cert, through
// transport/stream.h) on one I/O thread, decodes
// their frames (protocol/wire, bounded), hands messages and the time to the core, runs the
// tick, handshake and idle timers, and writes the frames the core returns, gathered, in order.
// Every decision (admission, sequencing, durability, planning, budgets) is the core's.
//
// Every client input is untrusted: a frame that does not decode closes that client with an
// Error and a Bye, and none disturbs the others. A client that stops reading is dropped once
// its unsent data passes its bound (regions wait for it long before that: the core sends bulk
// only while a client's queue is under one second of its budget).
#pragma once

#include <asio.hpp>
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <string>

#include "protocol/wire/framing.h"
#include "server/metrics_http.h"
#include "server/replication/replication_core.h"
#include "server/server_config.h"
#include "server/storage.h"
#include "transport/stream.h"

namespace loam::server {

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
  uint16_t metrics_port() const { return metrics_.port(); }  // 0: no metrics endpoint
  // Graceful stop: stop accepting, make the log durable, write a snapshot, send Bye to every
  // client, then let the io_context run out.
  void shutdown(const std::string& reason);
  const ServerStats& stats() const { return core_.stats(); }
  bool failed() const { return core_.failed(); }

 private:
  struct Connection;
  using ConnectionPtr = std::shared_ptr<Connection>;

  void accept();
  void on_accept(asio::ip::tcp::socket socket);
  void read(const ConnectionPtr& c);
  // Hands the frames buffered for `c` to the core; false when reading must wait (the client
  // is over its request rate: read_pause resumes it) or the connection is closing.
  bool drain(const ConnectionPtr& c);
  // Queues the core's output: frames to their connections, then closes.
  void deliver();
  // Writes the core's log lines (the core reads no clock; a line's time is the writer's).
  void write_core_log(const std::vector<CoreLogLine>& lines);
  void queue(const ConnectionPtr& c, FramePtr frame);
  void flush(const ConnectionPtr& c);
  void close_after_flush(const ConnectionPtr& c);
  void finish_close(const ConnectionPtr& c, const std::string& reason);
  void arm_timer(const ConnectionPtr& c, double seconds, bool handshake);
  void wait_for_reload();
  void schedule_tick();
  void tick();
  void schedule_stats();

  asio::io_context& io_;
  ServerConfig config_;
  TransportCounters counters_;  // bytes in and out, TLS failures, the largest queue: the core reads them
  ReplicationCore core_;
  std::shared_ptr<asio::ssl::context> tls_;  // --tls-cert/--tls-key; null: plain TCP
  asio::ip::tcp::acceptor acceptor_;
  MetricsHttp metrics_;  // --metrics-bind
  asio::steady_timer tick_timer_;
  asio::steady_timer stats_timer_;
  asio::signal_set signals_;
  // SIGHUP: the tokens are read again (a rotated secret); connected clients keep their roles.
  asio::signal_set reload_signal_;
  std::chrono::steady_clock::time_point next_tick_;
  std::map<ClientId, ConnectionPtr> connections_;
  uint16_t port_ = 0;
  bool stopping_ = false;
};

}  // namespace loam::server
