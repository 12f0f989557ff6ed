// Running one of the project's programs to completion in a test, with its output captured:
// what the start-up checks and the exit-code tests need.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "integration_util.h"
#include "tests/support/child_process.h"

namespace loam::test {

struct Ran {
  int exit_code = -1;  // -1: did not exit normally
  std::string output;  // stdout and stderr together
};

// Runs a program to completion with stdout and stderr captured.
inline Ran run(std::vector<std::string> args) {
  // A folder per run: tests run several programs at once (bots on threads).
  static std::atomic<int> runs{0};
  const std::string out = temp_data_dir("run" + std::to_string(runs++)) + "/output";
  const pid_t pid = spawn_child(std::move(args), out, out);
  Ran r;
  if (pid < 0) return r;
  // A check that failed to refuse leaves a server running: stop it after a deadline.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) != pid) {
    if (std::chrono::steady_clock::now() > deadline) {
      ::kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      r.output = "(still running after 60 s: killed)\n";
      return r;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));  // polling the child's exit
  }
  if (WIFEXITED(status)) r.exit_code = WEXITSTATUS(status);
  std::ifstream f(out);
  std::stringstream s;
  s << f.rdbuf();
  r.output += s.str();
  return r;
}

}  // namespace loam::test
