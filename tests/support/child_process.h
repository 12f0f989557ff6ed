// Child processes of the tests and the benchmark suites (the project's programs, GDAL's
// tools): started with their output in files, waited for with their exit status and peak RSS
// (wait4's rusage), which is how a suite measures a program's memory without counting its own.
#pragma once

#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <string>
#include <vector>

extern char** environ;

namespace loam::test {

// Starts `args` (argv[0] is looked up on PATH when it has no slash) with stdout written to
// `stdout_path` and stderr to `stderr_path`: empty leaves it this process's, the same path as
// stdout shares that file. Its pid, or -1.
inline pid_t spawn_child(std::vector<std::string> args, const std::string& stdout_path,
                         const std::string& stderr_path) {
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, stdout_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (stderr_path == stdout_path) {
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
  } else if (!stderr_path.empty()) {
    posix_spawn_file_actions_addopen(&actions, 2, stderr_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  }
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

}  // namespace loam::test
