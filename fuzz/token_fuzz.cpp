// libFuzzer target for the tokens-file reader (a file an operator writes, so untrusted):
// parse_token_lines() on arbitrary bytes. Properties checked (abort on violation):
//  - it returns a token list or an error, never crashes or reads out of bounds;
//  - every token it accepted prints and parses back to itself;
//  - the accepted list printed as a tokens file parses to the same list.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>

#include "protocol/wire/access_token.h"

namespace {

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "token_fuzz property violated: %s\n", what);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace loam::wire;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  AccessTokenList list;
  if (!parse_token_lines(text, "fuzz", list).ok()) return 0;
  std::string printed;
  for (const auto* role : {&list.editors, &list.viewers}) {
    for (const AccessToken& t : *role) {
      auto back = parse_access_token(format_access_token(t));
      if (!back || !access_tokens_equal(*back, t)) fail("a token does not survive print and parse");
      printed += (role == &list.editors ? "editor " : "viewer ") + format_access_token(t) + "\n";
    }
  }
  AccessTokenList again;
  if (!parse_token_lines(printed, "printed", again).ok()) fail("the printed list does not parse");
  if (again.editors != list.editors || again.viewers != list.viewers) fail("the printed list differs");
  return 0;
}
