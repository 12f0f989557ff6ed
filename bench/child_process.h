// Child processes of the suites (the project's programs, GDAL's tools): started with their
// output in a file, waited for with their exit status and peak RSS (wait4's rusage), which is
// how the suites measure a program's memory without counting their own.
#pragma once

#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>
#include <vector>

extern char** environ;

namespace loam::bench {

// Starts `args` (argv[0] is looked up on PATH when it has no slash) with stdout, and stderr
// too when `with_stderr`, written to `output_path`. Its pid, or -1.
inline pid_t spawn_child(std::vector<std::string> args, const std::string& output_path, bool with_stderr) {
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, output_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (with_stderr) posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = -1;
  if (posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&actions);
  return pid;
}

struct ChildExit {
  bool waited = false;  // wait4 answered for it
  bool exited = false;  // it exited (was not killed by a signal)
  int code = -1;
  double peak_rss_mib = 0;
  bool ok() const { return exited && code == 0; }
};

inline ChildExit wait_child(pid_t pid) {
  ChildExit e;
  int status = 0;
  rusage usage{};
  if (pid <= 0 || wait4(pid, &status, 0, &usage) != pid) return e;
  e.waited = true;
  e.peak_rss_mib = double(usage.ru_maxrss) / 1024.0;
  e.exited = WIFEXITED(status);
  if (e.exited) e.code = WEXITSTATUS(status);
  return e;
}

}  // namespace loam::bench
