#include "transport/stream.h"

#include <openssl/ssl.h>

namespace loam::transport {

Stream::Stream(asio::ip::tcp::socket socket, std::shared_ptr<asio::ssl::context> tls)
    : context_(std::move(tls)) {
  if (context_)
    tls_ = std::make_unique<asio::ssl::stream<asio::ip::tcp::socket>>(std::move(socket), *context_);
  else
    plain_.emplace(std::move(socket));
}

void Stream::set_server_name(const std::string& name) {
  asio::error_code ec;
  asio::ip::make_address(name, ec);
  if (tls_ && ec && !name.empty()) SSL_set_tlsext_host_name(tls_->native_handle(), name.c_str());
}

void Stream::async_handshake(asio::ssl::stream_base::handshake_type type, Done done) {
  if (tls_) {
    tls_->async_handshake(type, std::move(done));
    return;
  }
  asio::post(plain_->get_executor(), [d = std::move(done)] { d(asio::error_code()); });
}

void Stream::async_write(const std::vector<asio::const_buffer>& buffers, Transferred done) {
  if (!tls_) {
    asio::async_write(*plain_, buffers, std::move(done));
    return;
  }
  size_t total = 0;
  for (const asio::const_buffer& b : buffers) total += b.size();
  // A burst's large buffer is not kept for a connection's life.
  if (staging_.capacity() > (size_t(1) << 20) && total < staging_.capacity() / 4)
    std::vector<uint8_t>().swap(staging_);
  staging_.clear();
  staging_.reserve(total);
  for (const asio::const_buffer& b : buffers) {
    const auto* p = static_cast<const uint8_t*>(b.data());
    staging_.insert(staging_.end(), p, p + b.size());
  }
  asio::async_write(*tls_, asio::buffer(staging_), std::move(done));
}

void Stream::close() {
  asio::error_code ec;
  socket().shutdown(asio::ip::tcp::socket::shutdown_both, ec);
  socket().close(ec);
}

}  // namespace loam::transport
