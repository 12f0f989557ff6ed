// Who may join a session and as what: the editor and viewer tokens of `loam-server serve`,
// from --editor-token/--viewer-token and from a tokens file (--tokens-file, the form secrets
// are mounted in: Kubernetes Secrets, systemd credentials, Docker secrets). Every token is
// checked when the server starts, so a typo is an error there, not a session nobody can join.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "protocol/result.h"
#include "protocol/wire/messages.h"

namespace loam::server {

struct ServerConfig;

struct AccessTokens {
  std::vector<wire::SessionToken> editors;  // grant the role a client asks for
  std::vector<wire::SessionToken> viewers;  // grant spectator only
  bool deny_all = false;  // the configured tokens could not be read: nobody gets in (fail closed)
  bool required() const { return deny_all || !editors.empty() || !viewers.empty(); }
};

enum class Access { kAsRequested, kSpectator, kDenied };

// A Hello's token against the tokens (no tokens configured: everyone as requested).
Access check_access(const AccessTokens& tokens, const std::optional<wire::SessionToken>& presented);

// Adds a tokens file's lines to `out`: `editor HEX` or `viewer HEX`, one per line; blank
// lines and lines starting with '#' are skipped. `source` names the file in errors, with the
// line number.
Status parse_tokens_text(std::string_view text, const std::string& source, AccessTokens& out);

// The flags' tokens and the tokens file's, all validated.
Result<AccessTokens> load_access_tokens(const ServerConfig& config);

}  // namespace loam::server
