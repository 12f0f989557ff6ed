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
#include "protocol/wire/access_token.h"
#include "protocol/wire/messages.h"

namespace loam::server {

struct ServerConfig;

struct AccessTokens : wire::AccessTokenList {
  bool deny_all = false;  // the configured tokens could not be read: nobody gets in (fail closed)
  bool required() const { return deny_all || !editors.empty() || !viewers.empty(); }
};

enum class Access { kAsRequested, kSpectator, kDenied };

// A Hello's token against the tokens (no tokens configured: everyone as requested).
Access check_access(const AccessTokens& tokens, const std::optional<wire::AccessToken>& presented);

// The flags' tokens and the tokens file's, all validated.
Result<AccessTokens> load_access_tokens(const ServerConfig& config);

// The mode ("0644") of a tokens file its group or others may read, which serve warns about;
// nullopt when only its owner may (or when it cannot be stat'ed: loading reports that).
std::optional<std::string> tokens_file_exposure(const std::string& path);

// Writes a secret to `path`, created with mode 0600 in the same open(O_CREAT | O_EXCL) call,
// so no other user can open it at any moment. An existing file is an error (kIo naming the
// path) unless `overwrite`; then the text goes to a fresh 0600 file beside it, renamed over
// the old one (atomic: a reader sees the old file or the new, never a mix). `tokens new FILE`.
Status write_private_file(const std::string& path, const std::string& text, bool overwrite);

}  // namespace loam::server
