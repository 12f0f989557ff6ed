// TLS settings for the client connection. The server presents a certificate chain and key
// (--tls-cert/--tls-key); a client verifies it against a CA file (with the host name), the
// system's CAs, or a pinned SHA-256 fingerprint of the server's certificate (a self-signed
// one, no CA needed). Building a context reads and checks the files, so a wrong path or a key
// that does not match the certificate is an error at start, not at the first client.
#pragma once

#include <array>
#include <asio/ssl/context.hpp>
#include <cstdint>
#include <memory>
#include <string>

#include "protocol/result.h"

namespace loam::transport {

using Sha256 = std::array<uint8_t, 32>;

struct TlsClientOptions {
  bool enabled = false;
  std::string ca_file;      // PEM CA bundle; empty: the system's CAs (unless pinned)
  std::string fingerprint;  // SHA-256 of the server's certificate (hex, colons allowed)
  // The name checked against the certificate (and sent as SNI); empty: the host connected to.
  std::string server_name;
};

// TLS 1.2 or newer, server side.
Result<std::shared_ptr<asio::ssl::context>> make_server_context(const std::string& cert_file,
                                                                const std::string& key_file);
// Client side, verifying the server named `host` (a DNS name or an IP address).
Result<std::shared_ptr<asio::ssl::context>> make_client_context(const TlsClientOptions& options,
                                                                const std::string& host);

// "AB:CD:…" or "abcd…" (64 hex digits) into bytes.
Result<Sha256> parse_fingerprint(const std::string& text);
// The SHA-256 fingerprint of the first certificate in a PEM file, as a client pins it.
Result<Sha256> certificate_fingerprint(const std::string& pem_file);
// Colon-separated upper-case hex, as `openssl x509 -fingerprint -sha256` prints it.
std::string fingerprint_text(const Sha256& f);

}  // namespace loam::transport
