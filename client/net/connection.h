// A client's TCP connection to a loam-server (TLS when set_tls asks for it, through
// transport/stream.h): handshake, framed send, and a thread-safe
// inbox of decoded messages filled by a background I/O thread (Asio). Incoming bytes go
// through protocol/wire's FrameAssembler (bounded; a decode error closes the connection and
// is reported as the inbox's final item). Ports and timeouts are the caller's (tests use
// ephemeral ports and wait for messages, never sleep).
#pragma once

#include <array>
#include <asio.hpp>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "protocol/result.h"
#include "protocol/wire/framing.h"
#include "protocol/wire/messages.h"
#include "transport/stream.h"
#include "transport/tls_context.h"

namespace loam::client {

class Connection {
 public:
  Connection();
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  // TLS for the next connect (the server's certificate checked as the options say).
  void set_tls(transport::TlsClientOptions options) { tls_ = std::move(options); }
  // Connects and performs the handshake (TLS's, then the protocol's); returns the server's Welcome, or its
  // Error as an Error (kUnauthorized, kUnsupported for a version mismatch, ...).
  Result<wire::Welcome> connect(const std::string& host, uint16_t port, const wire::Hello& hello,
                                std::chrono::milliseconds timeout = std::chrono::seconds(10));
  // Queues a message (thread-safe). Fails if it does not encode or the connection is closed.
  Status send(const wire::Message& m);
  // Queues raw bytes (tests of the server's decoder).
  void send_raw(std::vector<uint8_t> bytes);
  // Next decoded message, waiting up to `timeout`; nullopt on timeout. After the peer closes,
  // returns an Error once the inbox is drained.
  Result<std::optional<wire::Message>> next(std::chrono::milliseconds timeout);
  bool open() const;
  void close();
  uint64_t bytes_in() const { return bytes_in_; }
  uint64_t bytes_out() const { return bytes_out_; }
  // Bytes received in frames of one message type (header included).
  uint64_t bytes_in_of(wire::MessageType type) const { return bytes_in_by_type_[size_t(type)]; }
  // Stops reading from the socket (a test of a client that never reads).
  void pause_reading();

 private:
  void start_read();
  void do_write();
  void push(Result<wire::Message> m);

  asio::io_context io_;
  transport::TlsClientOptions tls_;
  std::optional<transport::Stream> stream_;
  bool secured_ = false;  // io thread: the TLS handshake is done (at once without TLS)
  std::optional<asio::executor_work_guard<asio::io_context::executor_type>> work_;
  std::thread thread_;
  wire::FrameAssembler assembler_;
  std::array<uint8_t, 64 * 1024> buffer_{};
  std::deque<std::vector<uint8_t>> out_;  // io thread only; held until the stream is secured
  bool writing_ = false;
  bool paused_ = false;

  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<wire::Message> inbox_;
  std::optional<Error> closed_error_;
  bool closed_ = false;
  std::atomic<uint64_t> bytes_in_{0}, bytes_out_{0};
  std::array<std::atomic<uint64_t>, wire::kLastMessageType + 1> bytes_in_by_type_{};
};

}  // namespace loam::client
