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

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

}  // namespace

Access check_access(const AccessTokens& tokens, const std::optional<wire::SessionToken>& presented) {
  if (!tokens.required()) return Access::kAsRequested;
  if (tokens.deny_all || !presented) return Access::kDenied;
  if (contains(tokens.editors, *presented)) return Access::kAsRequested;
  if (contains(tokens.viewers, *presented)) return Access::kSpectator;
  return Access::kDenied;
}

Status parse_tokens_text(std::string_view text, const std::string& source, AccessTokens& out) {
  size_t line_no = 0;
  while (!text.empty()) {
    const size_t end = text.find('\n');
    std::string_view line = trim(text.substr(0, end));
    text.remove_prefix(end == std::string_view::npos ? text.size() : end + 1);
    ++line_no;
    if (line.empty() || line.front() == '#') continue;
    const std::string where = source + ":" + std::to_string(line_no);
    const size_t space = line.find_first_of(" \t");
    if (space == std::string_view::npos)
      return make_error(ErrorCode::kInvalidArgument, where, "expected 'editor TOKEN' or 'viewer TOKEN'");
    const std::string_view role = line.substr(0, space);
    const std::string_view hex = trim(line.substr(space + 1));
    std::vector<wire::SessionToken>* list = role == "editor"   ? &out.editors
                                            : role == "viewer" ? &out.viewers
                                                               : nullptr;
    if (!list)
      return make_error(ErrorCode::kInvalidArgument, where,
                        "unknown role '" + std::string(role) + "' (editor or viewer)");
    auto token = wire::parse_session_token(hex, where);
    if (!token) return token.error();
    list->push_back(*token);
  }
  return {};
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
    LOAM_TRY(parse_tokens_text(text.str(), config.tokens_file, out));
    if (out.editors.empty() && out.viewers.empty())
      return make_error(ErrorCode::kInvalidArgument, config.tokens_file,
                        "the tokens file holds no token (an empty file would let everyone edit)");
  }
  return out;
}

}  // namespace loam::server
