#include "protocol/wire/access_token.h"

namespace loam::wire {
namespace {

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

}  // namespace

Result<AccessToken> parse_access_token(std::string_view hex, const std::string& field) {
  if (hex.size() != 2 * kAccessTokenBytes) {
    return make_error(ErrorCode::kInvalidArgument, field,
                      "an access token is " + std::to_string(2 * kAccessTokenBytes) + " hex digits, got " +
                          std::to_string(hex.size()) + " characters");
  }
  AccessToken t{};
  for (size_t i = 0; i < t.size(); ++i) {
    const int hi = hex_value(hex[2 * i]), lo = hex_value(hex[2 * i + 1]);
    if (hi < 0 || lo < 0) {
      return make_error(ErrorCode::kInvalidArgument, field,
                        "an access token holds only hex digits (0-9, a-f); character " +
                            std::to_string(2 * i + (hi < 0 ? 1 : 2)) + " is not one");
    }
    t[i] = uint8_t(hi << 4 | lo);
  }
  return t;
}

std::string format_access_token(const AccessToken& token) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string out;
  out.reserve(2 * token.size());
  for (uint8_t b : token) {
    out.push_back(kDigits[b >> 4]);
    out.push_back(kDigits[b & 15]);
  }
  return out;
}

bool access_tokens_equal(const AccessToken& a, const AccessToken& b) {
  uint8_t diff = 0;
  for (size_t i = 0; i < a.size(); ++i) diff = uint8_t(diff | (a[i] ^ b[i]));
  return diff == 0;
}

Status parse_token_lines(std::string_view text, const std::string& source, AccessTokenList& out) {
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
    std::vector<AccessToken>* list = role == "editor"   ? &out.editors
                                     : role == "viewer" ? &out.viewers
                                                        : nullptr;
    if (!list)
      return make_error(ErrorCode::kInvalidArgument, where,
                        "unknown role '" + std::string(role) + "' (editor or viewer)");
    auto token = parse_access_token(hex, where);
    if (!token) return token.error();
    list->push_back(*token);
  }
  return {};
}

}  // namespace loam::wire
