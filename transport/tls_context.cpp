#include "transport/tls_context.h"

#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>

#include <asio/ip/address.hpp>
#include <asio/ssl/host_name_verification.hpp>
#include <asio/ssl/verify_context.hpp>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>

namespace loam::transport {

namespace {

constexpr auto kOptions = asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                          asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 |
                          asio::ssl::context::no_tlsv1_1 | asio::ssl::context::single_dh_use;

Status readable(const std::string& path, const char* what) {
  if (path.empty()) return make_error(ErrorCode::kInvalidArgument, what, "no file given");
  std::ifstream f(path, std::ios::binary);
  if (!f) return make_error(ErrorCode::kIo, path, std::string("cannot read the ") + what);
  return {};
}

std::optional<Sha256> digest(X509* cert) {
  Sha256 out{};
  unsigned n = 0;
  if (cert == nullptr || X509_digest(cert, EVP_sha256(), out.data(), &n) != 1 || n != out.size())
    return std::nullopt;
  return out;
}

}  // namespace

Result<std::shared_ptr<asio::ssl::context>> make_server_context(const std::string& cert_file,
                                                                const std::string& key_file) {
  LOAM_TRY(readable(cert_file, "TLS certificate (--tls-cert)"));
  LOAM_TRY(readable(key_file, "TLS key (--tls-key)"));
  auto ctx = std::make_shared<asio::ssl::context>(asio::ssl::context::tls_server);
  asio::error_code ec;
  ctx->set_options(kOptions, ec);
  if (!ec) ctx->use_certificate_chain_file(cert_file, ec);
  if (ec) return make_error(ErrorCode::kCorrupt, cert_file, "not a PEM certificate chain: " + ec.message());
  ctx->use_private_key_file(key_file, asio::ssl::context::pem, ec);
  if (!ec && SSL_CTX_check_private_key(ctx->native_handle()) != 1) ec = asio::error::invalid_argument;
  if (ec) {
    // A readable key of another certificate, or no key at all: say which.
    BIO* bio = BIO_new_file(key_file.c_str(), "r");
    EVP_PKEY* key = bio ? PEM_read_bio_PrivateKey(bio, nullptr, nullptr, nullptr) : nullptr;
    const bool is_key = key != nullptr;
    EVP_PKEY_free(key);
    BIO_free(bio);
    if (is_key)
      return make_error(ErrorCode::kInvalidArgument, key_file,
                        "the key does not match the certificate " + cert_file);
    return make_error(ErrorCode::kCorrupt, key_file, "not a PEM private key: " + ec.message());
  }
  return ctx;
}

Result<std::shared_ptr<asio::ssl::context>> make_client_context(const TlsClientOptions& o,
                                                                const std::string& host) {
  auto ctx = std::make_shared<asio::ssl::context>(asio::ssl::context::tls_client);
  asio::error_code ec;
  ctx->set_options(kOptions, ec);
  ctx->set_verify_mode(asio::ssl::verify_peer, ec);
  std::optional<Sha256> pin;
  if (!o.fingerprint.empty()) {
    auto p = parse_fingerprint(o.fingerprint);
    if (!p) return p.error();
    pin = *p;
  }
  const bool check_ca = !o.ca_file.empty() || !pin;
  if (!o.ca_file.empty()) {
    LOAM_TRY(readable(o.ca_file, "TLS CA file (--tls-ca)"));
    ctx->load_verify_file(o.ca_file, ec);
    if (ec) return make_error(ErrorCode::kCorrupt, o.ca_file, "not a PEM CA bundle: " + ec.message());
  } else if (check_ca) {
    ctx->set_default_verify_paths(ec);
    if (ec) return make_error(ErrorCode::kIo, "tls", "cannot load the system's CAs: " + ec.message());
  }
  const std::string name = o.server_name.empty() ? host : o.server_name;
  asio::ssl::host_name_verification host_check(name);
  ctx->set_verify_callback(
      [pin, check_ca, host_check](bool preverified, asio::ssl::verify_context& vc) mutable {
        X509_STORE_CTX* store = vc.native_handle();
        const bool leaf = X509_STORE_CTX_get_error_depth(store) == 0;
        // A CA (given or the system's) vouches for the chain and the name.
        if (check_ca && !host_check(preverified, vc)) return false;
        // A pin names the server's own certificate; the chain above it is not consulted.
        if (pin && leaf) {
          const auto d = digest(X509_STORE_CTX_get_current_cert(store));
          if (!d || *d != *pin) return false;
          if (!check_ca) X509_STORE_CTX_set_error(store, X509_V_OK);
        }
        return true;
      });
  return ctx;
}

Result<Sha256> parse_fingerprint(const std::string& text) {
  std::string hex;
  for (const char ch : text) {
    if (ch == ':' || ch == ' ') continue;
    if (!std::isxdigit(static_cast<unsigned char>(ch)))
      return make_error(ErrorCode::kInvalidArgument, "--tls-fingerprint", "not hex: '" + text + "'");
    hex.push_back(char(std::tolower(static_cast<unsigned char>(ch))));
  }
  Sha256 out{};
  if (hex.size() != 2 * out.size())
    return make_error(ErrorCode::kInvalidArgument, "--tls-fingerprint",
                      "a SHA-256 fingerprint is 64 hex digits, got " + std::to_string(hex.size()));
  for (size_t i = 0; i < out.size(); ++i) out[i] = uint8_t(std::stoul(hex.substr(2 * i, 2), nullptr, 16));
  return out;
}

Result<Sha256> certificate_fingerprint(const std::string& pem_file) {
  LOAM_TRY(readable(pem_file, "certificate"));
  BIO* bio = BIO_new_file(pem_file.c_str(), "r");
  if (bio == nullptr) return make_error(ErrorCode::kIo, pem_file, "cannot open the certificate");
  X509* cert = PEM_read_bio_X509(bio, nullptr, nullptr, nullptr);
  BIO_free(bio);
  const auto d = digest(cert);
  X509_free(cert);
  if (!d) return make_error(ErrorCode::kCorrupt, pem_file, "no PEM certificate in the file");
  return *d;
}

std::string fingerprint_text(const Sha256& f) {
  std::string out;
  char b[4];
  for (size_t i = 0; i < f.size(); ++i) {
    std::snprintf(b, sizeof b, i == 0 ? "%02X" : ":%02X", f[i]);
    out += b;
  }
  return out;
}

}  // namespace loam::transport
