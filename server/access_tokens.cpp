#include "server/access_tokens.h"

#include <fstream>
#include <sstream>

#include "protocol/wire/session_token.h"
#include "server/server_config.h"

namespace loam::server {
namespace {

bool contains(const std::vector<wire::SessionToken>& list, const wire::SessionToken& t) {
  bool found = false;
  for (const wire::SessionToken& x : list) found |= wire::session_tokens_equal(x, t);  // no early exit
  return found;
}

}  // namespace

Access check_access(const AccessTokens& tokens, const std::optional<wire::SessionToken>& presented) {
  if (!tokens.required()) return Access::kAsRequested;
  if (tokens.deny_all || !presented) return Access::kDenied;
  if (contains(tokens.editors, *presented)) return Access::kAsRequested;
  if (contains(tokens.viewers, *presented)) return Access::kSpectator;
  return Access::kDenied;
}

Result<AccessTokens> load_access_tokens(const ServerConfig& config) {
  AccessTokens out;
  for (const std::string& t : config.editor_tokens) {
    auto token = wire::parse_session_token(t, "--editor-token");
    if (!token) return token.error();
    out.editors.push_back(*token);
  }
  for (const std::string& t : config.viewer_tokens) {
    auto token = wire::parse_session_token(t, "--viewer-token");
    if (!token) return token.error();
    out.viewers.push_back(*token);
  }
  if (!config.tokens_file.empty()) {
    std::ifstream in(config.tokens_file, std::ios::binary);
    if (!in) return make_error(ErrorCode::kIo, config.tokens_file, "cannot read the tokens file");
    std::ostringstream text;
    text << in.rdbuf();
    LOAM_TRY(wire::parse_token_lines(text.str(), config.tokens_file, out));
    if (out.editors.empty() && out.viewers.empty())
      return make_error(ErrorCode::kInvalidArgument, config.tokens_file,
                        "the tokens file holds no token (an empty file would let everyone edit)");
  }
  return out;
}

}  // namespace loam::server
