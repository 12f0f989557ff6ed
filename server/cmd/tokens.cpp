// loam-server tokens new [FILE]: a tokens file for --tokens-file with fresh random editor and
// viewer tokens, written with mode 0600 from the moment it exists (or to stdout).
#include <cstdio>
#include <memory>
#include <random>

#include "app/cli_checks.h"
#include "protocol/wire/access_token.h"
#include "server/access_tokens.h"
#include "server/cmd/command.h"

namespace loam::server::cmd {

namespace {

struct TokensOptions {
  int editors = 1, viewers = 1;
  std::string out;
  bool force = false;
};

int new_tokens(const TokensOptions& o) {
  if (o.editors + o.viewers == 0)
    die(make_error(ErrorCode::kInvalidArgument, "tokens new", "no tokens asked for"));
  // 128 bits each from the kernel's generator (std::random_device reads getrandom here).
  std::random_device rd;
  auto fresh = [&] {
    wire::AccessToken t;
    for (size_t i = 0; i < t.size(); i += 4) {
      const uint32_t v = rd();
      for (size_t b = 0; b < 4; ++b) t[i + b] = uint8_t(v >> (8 * b));
    }
    return wire::format_access_token(t);
  };
  std::string text =
      "# loam-server tokens file (--tokens-file): an editor token lets a client deform,\n"
      "# a viewer token only watch. Keep this file secret (chmod 600).\n";
  for (int i = 0; i < o.editors; ++i) text += "editor " + fresh() + "\n";
  for (int i = 0; i < o.viewers; ++i) text += "viewer " + fresh() + "\n";
  if (o.out.empty()) {
    std::fputs(text.c_str(), stdout);
  } else if (const Status st = write_private_file(o.out, text, o.force); !st.ok()) {
    die(st.error());
  }
  return 0;
}

}  // namespace

Command add_tokens(CLI::App& app) {
  auto o = std::make_shared<TokensOptions>();
  auto* tokens_cmd = app.add_subcommand("tokens", "Access tokens");
  tokens_cmd->require_subcommand(1);
  auto* new_cmd = tokens_cmd->add_subcommand(
      "new",
      "Write a tokens file with fresh random tokens (for --tokens-file): to FILE (mode 0600), or stdout");
  auto* file_opt = new_cmd->add_option("file", o->out, "File to create with mode 0600 (default: stdout)");
  new_cmd->add_flag("--force", o->force, "Replace FILE if it exists")->needs(file_opt);
  new_cmd->add_option("--editors", o->editors, "Editor tokens")
      ->capture_default_str()
      ->check(cli::IntRange(0, 1000));
  new_cmd->add_option("--viewers", o->viewers, "Viewer tokens")
      ->capture_default_str()
      ->check(cli::IntRange(0, 1000));
  return {tokens_cmd, [o, new_cmd] { return *new_cmd ? new_tokens(*o) : 0; }};
}

}  // namespace loam::server::cmd
