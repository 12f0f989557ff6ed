// Access tokens as people write them: 32 hexadecimal digits (16 bytes) in config files,
// secrets and command lines. The wire carries the 16 bytes (Hello.access_token); this is
// the one place the text form is parsed and printed, for the server and every client.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "protocol/result.h"
#include "protocol/wire/messages.h"

namespace loam::wire {

// Exactly 32 hex digits, either case, no prefix or spaces; anything else is kInvalidArgument
// naming `field` (the flag or file line the text came from).
Result<AccessToken> parse_access_token(std::string_view hex, const std::string& field = "token");

// 32 lowercase hex digits.
std::string format_access_token(const AccessToken& token);

// Compares in time independent of where the tokens first differ (no early exit), so response
// timing tells a guesser nothing about a prefix.
bool access_tokens_equal(const AccessToken& a, const AccessToken& b);

// A tokens file, the form tokens are kept in as secrets (Kubernetes Secrets, systemd
// credentials, Docker secrets): `editor HEX` or `viewer HEX`, one per line; blank lines and
// lines starting with '#' are skipped. The server reads it for who may join
// (server/access_tokens.h), a client for the token it presents.
struct AccessTokenList {
  std::vector<AccessToken> editors;  // grant the role a client asks for
  std::vector<AccessToken> viewers;  // grant spectator only
};

// Adds the lines of `text` to `out`; errors name `source` and the line ("tokens:3").
Status parse_token_lines(std::string_view text, const std::string& source, AccessTokenList& out);

}  // namespace loam::wire
