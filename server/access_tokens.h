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
#include "protocol/wire/session_token.h"

namespace loam::server {

struct ServerConfig;

struct AccessTokens : wire::SessionTokenList {
  bool deny_all = false;  // the configured tokens could not be read: nobody gets in (fail closed)
  bool required() const { return deny_all || !editors.empty() || !viewers.empty(); }
};

enum class Access { kAsRequested, kSpectator, kDenied };

// A Hello's token against the tokens (no tokens configured: everyone as requested).
Access check_access(const AccessTokens& tokens, const std::optional<wire::SessionToken>& presented);

// The flags' tokens and the tokens file's, all validated.
Result<AccessTokens> load_access_tokens(const ServerConfig& config);

}  // namespace loam::server
