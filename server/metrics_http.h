// `--metrics-bind HOST:PORT`: a minimal HTTP/1.0 endpoint on the server's I/O thread that
// answers GET /metrics with the Prometheus text (metrics.h) and anything else with 404. Each
// request is bounded (8 KiB of headers, 5 s), a few connections at a time; it reads nothing
// of the session and changes nothing.
#pragma once

#include <asio.hpp>
#include <cstdint>
#include <functional>
#include <string>

#include "protocol/result.h"

namespace loam::server {

class MetricsHttp {
 public:
  MetricsHttp(asio::io_context& io, std::function<std::string()> body)
      : body_(std::move(body)), acceptor_(io) {}

  // Binds "HOST:PORT" (PORT 0: any free port) and starts accepting.
  Status start(const std::string& bind);
  uint16_t port() const { return port_; }
  void stop();

 private:
  void accept();

  std::function<std::string()> body_;
  asio::ip::tcp::acceptor acceptor_;
  uint16_t port_ = 0;
  int open_ = 0;  // connections being served
};

}  // namespace loam::server
