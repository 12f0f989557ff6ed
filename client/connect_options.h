// The options every connecting client command takes (loam-client's bot, view, render
// --server and probe, and loam-probe).
// TLS: --tls (verify against the system's CAs), --tls-ca FILE (a CA bundle) or
// --tls-fingerprint SHA256 (also LOAM_TLS_FINGERPRINT: the server's certificate, pinned; the
// server logs it at start), either of which implies --tls; --tls-name NAME checks the
// certificate for another name than the host's.
// The token: --token HEX (also LOAM_TOKEN, which keeps it off the
// command line and out of `ps`) or --token-file FILE (also LOAM_TOKEN_FILE; a mounted
// secret: the bare token, or the server's tokens file, of which an editing command takes the
// first editor token and a watching one the first viewer token).
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>

#include "protocol/result.h"
#include "protocol/wire/messages.h"
#include "transport/tls_context.h"

namespace loam::client {

struct TokenSource {
  std::string hex, file;
};

void add_token_options(CLI::App* cmd, TokenSource& src);
void add_tls_options(CLI::App* cmd, transport::TlsClientOptions& tls);

// The token in a file: the file's whole text, or a tokens file's first editor (editing) or
// viewer (watching) token, falling back to the other role.
Result<wire::AccessToken> token_from_file(const std::string& path, bool editing);

// Resolves the options into `out` (left empty when neither was given); false, after saying
// why on stderr, when the token is unusable.
bool resolve_token(const char* cmd, const TokenSource& src, bool editing,
                   std::optional<wire::AccessToken>& out);

}  // namespace loam::client
