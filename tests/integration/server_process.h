// Runs a real loam-server process for integration tests: ephemeral port (read back from
// --port-file), its own data folder, stderr captured to a file for diagnostics. Waiting for
// start-up polls the port file with a deadline; the tests themselves wait for messages.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/child_process.h"

namespace loam::test {

class ServerProcess {
 public:
  ServerProcess() = default;
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;
  ~ServerProcess() { kill9(); }

  // Starts `loam-server serve` on an ephemeral port with `data_dir`; false if it did not come
  // up within the timeout (then log() says why).
  bool start(const std::string& data_dir, std::vector<std::string> extra = {},
             std::chrono::milliseconds timeout = std::chrono::seconds(60)) {
    namespace fs = std::filesystem;
    fs::create_directories(data_dir);
    port_file_ = data_dir + "/port";
    log_file_ = data_dir + "/server.log." + std::to_string(++starts_);
    fs::remove(port_file_);
    std::vector<std::string> args = {LOAM_SERVER_BINARY, "serve",    "--port",     "0",
                                     "--port-file",      port_file_, "--data-dir", data_dir,
                                     "--stats-interval", "0"};
    // Regions stream without a byte budget unless a test sets one (--client-budget): most
    // tests wait for whole worlds and test other things; the streaming tests set it.
    if (std::find(extra.begin(), extra.end(), "--client-budget") == extra.end()) {
      args.push_back("--client-budget");
      args.push_back("0");
    }
    args.insert(args.end(), extra.begin(), extra.end());
    pid_ = spawn_child(std::move(args), "/dev/null", log_file_);
    if (pid_ < 0) return false;
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      std::ifstream f(port_file_);
      int port = 0;
      if (f >> port && port > 0) {
        port_ = uint16_t(port);
        return true;
      }
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return false;  // exited during start-up
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));  // polling a file, not waiting on a message
    }
    return false;
  }

  uint16_t port() const { return port_; }
  bool running() const { return pid_ > 0; }
  pid_t pid() const { return pid_; }

  void kill9() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
  }

  // SIGTERM and wait; returns the exit code (-1 if it did not exit normally in time).
  int terminate(std::chrono::milliseconds timeout = std::chrono::seconds(60)) {
    if (pid_ <= 0) return -1;
    ::kill(pid_, SIGTERM);
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      int status = 0;
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    kill9();
    return -1;
  }

  std::string log() const {
    std::ifstream f(log_file_);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
  }

 private:
  pid_t pid_ = -1;
  uint16_t port_ = 0;
  int starts_ = 0;
  std::string port_file_, log_file_;
};

}  // namespace loam::test
