// A live session on the GPU stamp backend (llvmpipe here; `auto` picks it on a machine with a
// GPU): bots deform through a server that applies on the GPU from its apply worker, and the
// world it ends with is the world its log replays to. Without an EGL display the test is
// skipped, visibly, except under CI=true, where it fails (as the GL tests do).
#include <gtest/gtest.h>

#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

#include "client/bot.h"
#include "integration_util.h"
#include "program_run.h"
#include "server_process.h"

namespace loam::test {
namespace {

#ifdef LOAM_CLIENT_BINARY

std::string listening_world_hash(const std::string& log) {
  const size_t line = log.find("event=listening ");
  const size_t at = line == std::string::npos ? line : log.find("world_hash=", line);
  return at == std::string::npos ? std::string() : log.substr(at + 11, 16);
}

TEST(GpuBackendSession, BotsStampingThroughTheGpuSeeNoMismatchAndTheWorldIsWhatItsLogReplaysTo) {
  const std::string dir = temp_data_dir("gpu_session");
  ServerProcess server;
  if (!server.start(dir, {"--backend", "gpu", "--hashes-every", "10"})) {
    const char* ci = std::getenv("CI");
    if (server.log().find("no EGL display") != std::string::npos && !(ci && std::strcmp(ci, "true") == 0))
      GTEST_SKIP() << "no EGL display";
    FAIL() << server.log();
  }
  ASSERT_NE(server.log().find("chosen=gpu"), std::string::npos) << server.log();
  // Two bots at once, one roaming (subscribing by distance, stamping near itself).
  Ran a, b;
  std::thread other([&] {
    b = run({LOAM_CLIENT_BINARY, "bot", "--port", std::to_string(server.port()), "--name", "roamer",
             "--stamps", "40", "--rate", "40", "--seed", "5", "--roam", "50"});
  });
  a = run({LOAM_CLIENT_BINARY, "bot", "--port", std::to_string(server.port()), "--name", "still", "--stamps",
           "40", "--rate", "40", "--seed", "9"});
  other.join();
  EXPECT_EQ(a.exit_code, client::kBotOk) << a.output;
  EXPECT_EQ(b.exit_code, client::kBotOk) << b.output;
  EXPECT_NE(a.output.find("40/40 stamps accepted"), std::string::npos) << a.output;
  EXPECT_NE(a.output.find("mismatches 0"), std::string::npos) << a.output;
  EXPECT_NE(b.output.find("mismatches 0"), std::string::npos) << b.output;
  EXPECT_EQ(server.log().find("event=backend_error"), std::string::npos) << server.log();
  EXPECT_EQ(server.terminate(), 0) << server.log();

  // The shutdown snapshot holds the live world: a restart (on the CPU) announces its hash,
  // which must be the hash of the log replayed from the initial terrain.
  ServerProcess again;
  ASSERT_TRUE(again.start(dir)) << again.log();
  EXPECT_NE(again.log().find("replayed=0"), std::string::npos) << again.log();
  char want[20];
  std::snprintf(want, sizeof want, "%016llx", (unsigned long long)replayed_world(dir, 80).world_hash());
  EXPECT_EQ(listening_world_hash(again.log()), want) << again.log();
  EXPECT_EQ(again.terminate(), 0) << again.log();
}

#endif

}  // namespace
}  // namespace loam::test
