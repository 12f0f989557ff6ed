// The subcommands of loam-server, one file each (serve.cpp, replay.cpp, log_tools.cpp, ...):
// each adds its subcommand and options to the program's CLI11 app and returns what to run when
// the user chose it. server/main.cpp is the table of them. Errors at start-up and in the tools
// are exceptions (die), caught in main with a clear message.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <string>
#include <vector>

#include "protocol/result.h"

namespace loam::server::cmd {

struct Command {
  CLI::App* app = nullptr;  // chosen when *app is true after parsing
  std::function<int()> run;
};

// Exit status of a verification tool (replay, log dump, log summary, pack verify) that could
// not read the whole input: its output does not describe the session (docs/configuration.md).
inline constexpr int kExitDamaged = 3;

[[noreturn]] void die(const Error& e);

// A data folder stands for its log segments; otherwise the arguments are segment files, and
// `data_dir` (when empty) becomes the folder two levels above the first (where snapshots live).
std::vector<std::string> expand_logs(const std::vector<std::string>& args, std::string* data_dir);

// In the order `loam-server --help` lists them.
Command add_serve(CLI::App& app);
Command add_replay(CLI::App& app);
Command add_import(CLI::App& app);
Command add_pack(CLI::App& app);
Command add_export(CLI::App& app);
Command add_log(CLI::App& app);
Command add_snapshot(CLI::App& app);
Command add_tokens(CLI::App& app);

}  // namespace loam::server::cmd
