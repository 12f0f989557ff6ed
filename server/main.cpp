// loam-server: host a multiplayer terrain session, and the file tools that go with it.
//   serve            run a session (TCP); SIGINT/SIGTERM stop it cleanly
//   replay LOG...    rebuild the world from a log and print its hash
//   import, export   DEM files in and out (import --pack: a tile pack of any size)
//   pack info|verify what a tile pack holds, and a check of every tile
//   log dump|summary human views of a deformation log
//   snapshot info    what a snapshot holds
//   tokens new       a fresh tokens file (random editor and viewer tokens) for --tokens-file
//
// Each subcommand lives in its own file under server/cmd/; this is the table of them.

#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#include <string>
#include <vector>

#include "protocol/log/log_format.h"
#include "protocol/wire/constants.h"
#include "server/cmd/command.h"

namespace {

using namespace loam::server;

// In the order --help lists them.
constexpr cmd::Command (*kCommands[])(CLI::App&) = {
    cmd::add_serve,  cmd::add_replay, cmd::add_import,   cmd::add_pack,
    cmd::add_export, cmd::add_log,    cmd::add_snapshot, cmd::add_tokens,
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"loam-server: host a Loam terrain session"};
  app.set_version_flag("--version", "loam-server " LOAM_VERSION " (protocol " +
                                        std::to_string(loam::wire::kProtocolMajor) + "." +
                                        std::to_string(loam::wire::kProtocolMinor) + ", log format " +
                                        std::to_string(loam::log::kLogFormatVersion) + ")");
  app.require_subcommand(1);
  app.set_config("--config", "", "Read options from an INI/TOML file (docs/configuration.md)");
  // A misspelt key in the file is an error, not a setting silently left at its default.
  app.allow_config_extras(CLI::config_extras_mode::error);
  std::vector<cmd::Command> commands;
  for (const auto add : kCommands) commands.push_back(add(app));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    for (const cmd::Command& c : commands) {
      if (*c.app) return c.run();
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "loam-server: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
