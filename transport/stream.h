// One connection's byte stream: a TCP socket, or TLS over it. The server and the clients read,
// write, handshake and close through it without caring which; framing stays in protocol/wire.
// Like an Asio stream it allows one read and one write in flight at a time. Over TLS a
// gathered write is copied into one buffer first, so a tick's frames leave as a few full
// records rather than a record (and a send) per frame.
#pragma once

#include <asio.hpp>
#include <asio/ssl.hpp>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace loam::transport {

class Stream {
 public:
  using Done = std::function<void(const asio::error_code&)>;
  using Transferred = std::function<void(const asio::error_code&, size_t)>;

  // `tls` null: plain TCP.
  Stream(asio::ip::tcp::socket socket, std::shared_ptr<asio::ssl::context> tls);
  Stream(const Stream&) = delete;
  Stream& operator=(const Stream&) = delete;

  asio::ip::tcp::socket& socket() { return tls_ ? tls_->next_layer() : *plain_; }
  bool encrypted() const { return tls_ != nullptr; }
  // Client side: the name sent as SNI (a DNS name; an IP address is not sent).
  void set_server_name(const std::string& name);

  // TLS: the handshake as `type`; plain TCP: `done` at once (posted), with no error.
  void async_handshake(asio::ssl::stream_base::handshake_type type, Done done);
  template <class MutableBuffers, class Handler>
  void async_read_some(const MutableBuffers& buffers, Handler&& handler) {
    if (tls_)
      tls_->async_read_some(buffers, std::forward<Handler>(handler));
    else
      plain_->async_read_some(buffers, std::forward<Handler>(handler));
  }
  // Writes all of `buffers` (they must outlive the write); `done` gets the bytes written.
  void async_write(const std::vector<asio::const_buffer>& buffers, Transferred done);
  // Shuts the socket down both ways and closes it; pending operations end with an error.
  void close();

 private:
  std::shared_ptr<asio::ssl::context> context_;  // kept alive as long as the stream
  std::unique_ptr<asio::ssl::stream<asio::ip::tcp::socket>> tls_;
  std::optional<asio::ip::tcp::socket> plain_;
  std::vector<uint8_t> staging_;  // TLS: the gathered write, contiguous
};

}  // namespace loam::transport
