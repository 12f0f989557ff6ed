#include "client/net/connection.h"

namespace loam::client {

using asio::ip::tcp;

Connection::Connection() : assembler_(wire::kAbsoluteMaxFrameBytes) {}

Connection::~Connection() { close(); }

Result<wire::Welcome> Connection::connect(const std::string& host, uint16_t port, const wire::Hello& hello,
                                          std::chrono::milliseconds timeout) {
  asio::error_code ec;
  tcp::resolver resolver(io_);
  const auto endpoints = resolver.resolve(host, std::to_string(port), ec);
  if (ec) return make_error(ErrorCode::kNotFound, host, "cannot resolve: " + ec.message());
  std::shared_ptr<asio::ssl::context> tls;
  if (tls_.enabled || !tls_.ca_file.empty() || !tls_.fingerprint.empty()) {
    auto ctx = transport::make_client_context(tls_, host);
    if (!ctx) return ctx.error();
    tls = *ctx;
  }
  tcp::socket socket(io_);
  asio::connect(socket, endpoints, ec);
  if (ec)
    return make_error(ErrorCode::kIo, host + ":" + std::to_string(port), "cannot connect: " + ec.message());
  socket.set_option(tcp::no_delay(true), ec);
  stream_.emplace(std::move(socket), tls);
  stream_->set_server_name(tls_.server_name.empty() ? host : tls_.server_name);
  work_.emplace(io_.get_executor());
  // Nothing is read or written before the TLS handshake (none without TLS) has succeeded.
  stream_->async_handshake(asio::ssl::stream_base::client, [this, host](const asio::error_code& e) {
    if (e) {
      push(make_error(ErrorCode::kUnauthorized, "tls",
                      "TLS handshake with " + host + " failed: " + e.message() +
                          (e.category() == asio::error::get_ssl_category()
                               ? " (is the server's certificate the one --tls-ca or --tls-fingerprint names, "
                                 "and does the server speak TLS?)"
                               : "")));
      return;
    }
    secured_ = true;
    start_read();
    do_write();
  });
  thread_ = std::thread([this] { io_.run(); });
  LOAM_TRY(send(hello));
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (true) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return make_error(ErrorCode::kIo, "welcome", "no Welcome within the timeout");
    auto m = next(left);
    if (!m) return m.error();
    if (!m->has_value()) continue;
    if (auto* w = std::get_if<wire::Welcome>(&**m)) return *w;
    if (auto* e = std::get_if<wire::ErrorMsg>(&**m)) {
      return make_error(wire::from_wire(e->code), e->field.empty() ? "server" : e->field, e->text);
    }
    // Anything else before Welcome is a protocol error on the server's side.
    return make_error(ErrorCode::kCorrupt, "welcome",
                      std::string("expected Welcome, got ") + wire::to_string(wire::message_type(**m)));
  }
}

void Connection::start_read() {
  stream_->async_read_some(asio::buffer(buffer_), [this](const asio::error_code& ec, size_t n) {
    if (ec) {
      push(make_error(ErrorCode::kIo, "connection",
                      ec == asio::error::eof ? "server closed the connection" : ec.message()));
      return;
    }
    bytes_in_ += n;
    assembler_.feed(std::span(buffer_.data(), n));
    while (true) {
      auto m = assembler_.next_message();
      if (!m) {
        push(m.error());
        return;
      }
      if (!m->has_value()) break;
      // Bytes by message type (what a stamp costs in events against regions): the frame
      // header plus the payload, measured again rather than threaded out of the assembler.
      if (const auto size = wire::measure_payload(**m)) {
        bytes_in_by_type_[size_t(wire::message_type(**m))] += *size + wire::kFrameHeaderBytes;
      }
      push(std::move(**m));
    }
    if (!paused_) start_read();
  });
}

void Connection::pause_reading() {
  asio::post(io_, [this] { paused_ = true; });
}

void Connection::push(Result<wire::Message> m) {
  std::lock_guard lock(mutex_);
  if (m.ok()) {
    inbox_.push_back(std::move(m.value()));
  } else if (!closed_error_) {
    closed_error_ = m.error();
  }
  cv_.notify_all();
}

Status Connection::send(const wire::Message& m) {
  auto frame = wire::encode_frame(m, wire::kAbsoluteMaxFrameBytes);
  if (!frame) return frame.error();
  send_raw(std::move(*frame));
  return {};
}

void Connection::send_raw(std::vector<uint8_t> bytes) {
  asio::post(io_, [this, b = std::move(bytes)]() mutable {
    out_.push_back(std::move(b));
    do_write();
  });
}

void Connection::do_write() {
  if (writing_ || out_.empty() || !secured_ || !stream_->socket().is_open()) return;
  writing_ = true;
  stream_->async_write({asio::buffer(out_.front())}, [this](const asio::error_code& ec, size_t n) {
    writing_ = false;
    if (ec) {
      push(make_error(ErrorCode::kIo, "connection", "write failed: " + ec.message()));
      return;
    }
    bytes_out_ += n;
    out_.pop_front();
    do_write();
  });
}

Result<std::optional<wire::Message>> Connection::next(std::chrono::milliseconds timeout) {
  std::unique_lock lock(mutex_);
  cv_.wait_for(lock, timeout, [&] { return !inbox_.empty() || closed_error_.has_value(); });
  if (!inbox_.empty()) {
    wire::Message m = std::move(inbox_.front());
    inbox_.pop_front();
    return std::optional<wire::Message>(std::move(m));
  }
  if (closed_error_) return *closed_error_;
  return std::optional<wire::Message>();
}

bool Connection::open() const {
  std::lock_guard lock(mutex_);
  return !closed_error_.has_value() && !closed_;
}

void Connection::close() {
  {
    std::lock_guard lock(mutex_);
    if (closed_) return;
    closed_ = true;
  }
  asio::post(io_, [this] {
    if (stream_) stream_->close();
  });
  work_.reset();
  if (thread_.joinable()) thread_.join();
}

}  // namespace loam::client
