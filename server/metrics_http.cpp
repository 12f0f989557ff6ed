#include "server/metrics_http.h"

#include <memory>

namespace loam::server {

namespace {

constexpr int kMaxOpen = 8;
constexpr size_t kMaxRequestBytes = 8192;

struct Exchange {
  explicit Exchange(asio::ip::tcp::socket s) : socket(std::move(s)), timer(socket.get_executor()) {}
  asio::ip::tcp::socket socket;
  asio::steady_timer timer;
  asio::streambuf request{kMaxRequestBytes};
  std::string response;
};

}  // namespace

Status MetricsHttp::start(const std::string& bind) {
  const size_t colon = bind.rfind(':');
  if (colon == std::string::npos || colon == 0)
    return make_error(ErrorCode::kInvalidArgument, "--metrics-bind", "expected HOST:PORT, got " + bind);
  asio::error_code ec;
  const auto address = asio::ip::make_address(bind.substr(0, colon), ec);
  if (ec) return make_error(ErrorCode::kInvalidArgument, "--metrics-bind", "bad address: " + bind);
  int port = -1;
  try {
    size_t used = 0;
    port = std::stoi(bind.substr(colon + 1), &used);
    if (used != bind.size() - colon - 1) port = -1;
  } catch (const std::exception&) {
    port = -1;
  }
  if (port < 0 || port > 65535)
    return make_error(ErrorCode::kInvalidArgument, "--metrics-bind", "bad port: " + bind);
  const asio::ip::tcp::endpoint ep(address, uint16_t(port));
  acceptor_.open(ep.protocol(), ec);
  if (!ec) acceptor_.set_option(asio::ip::tcp::acceptor::reuse_address(true), ec);
  if (!ec) acceptor_.bind(ep, ec);
  if (!ec) acceptor_.listen(16, ec);
  if (ec) return make_error(ErrorCode::kIo, "--metrics-bind", bind + ": " + ec.message());
  port_ = acceptor_.local_endpoint().port();
  accept();
  return {};
}

void MetricsHttp::stop() {
  asio::error_code ec;
  acceptor_.close(ec);
}

void MetricsHttp::accept() {
  acceptor_.async_accept([this](const asio::error_code& ec, asio::ip::tcp::socket socket) {
    if (ec == asio::error::operation_aborted || !acceptor_.is_open()) return;
    if (!ec && open_ < kMaxOpen) {
      ++open_;
      auto x = std::make_shared<Exchange>(std::move(socket));
      x->timer.expires_after(std::chrono::seconds(5));
      x->timer.async_wait([x](const asio::error_code& e) {
        if (e) return;
        asio::error_code ignore;
        x->socket.close(ignore);
      });
      asio::async_read_until(x->socket, x->request, "\r\n\r\n", [this, x](const asio::error_code& e, size_t) {
        if (e) {
          --open_;
          x->timer.cancel();
          return;
        }
        std::istream in(&x->request);
        std::string method, target;
        in >> method >> target;
        if (method == "GET" && (target == "/metrics" || target.rfind("/metrics?", 0) == 0)) {
          const std::string body = body_();
          x->response = "HTTP/1.0 200 OK\r\nContent-Type: text/plain; version=0.0.4\r\nContent-Length: " +
                        std::to_string(body.size()) + "\r\nConnection: close\r\n\r\n" + body;
        } else {
          x->response = "HTTP/1.0 404 Not Found\r\nContent-Length: 0\r\nConnection: close\r\n\r\n";
        }
        asio::async_write(x->socket, asio::buffer(x->response), [this, x](const asio::error_code&, size_t) {
          --open_;
          x->timer.cancel();
          asio::error_code ignore;
          x->socket.shutdown(asio::ip::tcp::socket::shutdown_both, ignore);
          x->socket.close(ignore);
        });
      });
    }
    accept();  // a refused connection (over kMaxOpen) closes as its socket goes
  });
}

}  // namespace loam::server
