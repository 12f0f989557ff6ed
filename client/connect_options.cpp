#include "client/connect_options.h"

#include <cctype>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "protocol/wire/access_token.h"

namespace loam::client {

void add_token_options(CLI::App* cmd, TokenSource& src) {
  auto* t = cmd->add_option("--token", src.hex, "Access token (32 hex digits) where the server has tokens")
                ->envname("LOAM_TOKEN");
  cmd->add_option("--token-file", src.file, "File holding the token, or a loam-server tokens file")
      ->envname("LOAM_TOKEN_FILE")
      ->excludes(t);
}

void add_tls_options(CLI::App* cmd, transport::TlsClientOptions& tls) {
  cmd->add_flag("--tls", tls.enabled, "Connect over TLS, verifying the server against the system's CAs");
  cmd->add_option("--tls-ca", tls.ca_file,
                  "Connect over TLS, verifying the server against this CA file (PEM)");
  cmd->add_option("--tls-fingerprint", tls.fingerprint,
                  "Connect over TLS to the server whose certificate has this SHA-256 fingerprint")
      ->envname("LOAM_TLS_FINGERPRINT");
  cmd->add_option("--tls-name", tls.server_name,
                  "The name the server's certificate must hold (default: the host)");
}

Result<wire::AccessToken> token_from_file(const std::string& path, bool editing) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error(ErrorCode::kIo, path, "cannot read the token file");
  std::ostringstream text;
  text << in.rdbuf();
  std::string s = text.str();
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.pop_back();
  if (s.size() == 2 * wire::kAccessTokenBytes && s.find_first_of(" \t\n#") == std::string::npos)
    return wire::parse_access_token(s, path);
  wire::AccessTokenList list;
  LOAM_TRY(wire::parse_token_lines(s, path, list));
  const auto& first = editing ? list.editors : list.viewers;
  const auto& second = editing ? list.viewers : list.editors;
  if (!first.empty()) return first.front();
  if (!second.empty()) return second.front();
  return make_error(ErrorCode::kNotFound, path, "the file holds no token");
}

// Resolves the token options; false (after saying why) when the token is unusable.
bool resolve_token(const char* cmd, const TokenSource& src, bool editing,
                   std::optional<wire::AccessToken>& out) {
  if (src.hex.empty() && src.file.empty()) return true;
  auto t =
      src.file.empty() ? wire::parse_access_token(src.hex, "--token") : token_from_file(src.file, editing);
  if (!t) {
    std::fprintf(stderr, "%s: %s\n", cmd, t.error().describe().c_str());
    return false;
  }
  out = *t;
  return true;
}

}  // namespace loam::client
