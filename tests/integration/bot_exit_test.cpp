// `loam-client bot`'s exit code, pinned: scripts and load tests read it. 0 only when every
// stamp was accepted and the hashes agreed; 4 when stamps were refused or lost with the link.
#include <gtest/gtest.h>

#include <chrono>
#include <string>
#include <thread>

#include "client/bot.h"
#include "integration_util.h"
#include "program_run.h"
#include "server_process.h"

namespace loam::test {
namespace {

#ifdef LOAM_CLIENT_BINARY

Ran run_bot(uint16_t port, int stamps, int rate) {
  return run({LOAM_CLIENT_BINARY, "bot", "--port", std::to_string(port), "--stamps", std::to_string(stamps),
              "--rate", std::to_string(rate)});
}

TEST(BotExit, ExitsZeroWhenEveryStampIsAccepted) {
  ServerProcess server;
  ASSERT_TRUE(server.start(temp_data_dir("bot_exit_ok"))) << server.log();
  const Ran r = run_bot(server.port(), 10, 50);
  EXPECT_EQ(r.exit_code, client::kBotOk) << r.output;
  EXPECT_NE(r.output.find("10/10 stamps accepted"), std::string::npos) << r.output;
}

TEST(BotExit, ExitsWithLostStampsWhenTheServerRefusesSome) {
  ServerProcess server;
  // The bot keeps to the rate and cap the Welcome announces, so refuse by cost: no stamp of
  // its mix costs as little as 100 sample updates.
  ASSERT_TRUE(server.start(temp_data_dir("bot_exit_refused"), {"--max-stamp-cost", "100"})) << server.log();
  const Ran r = run_bot(server.port(), 10, 50);
  EXPECT_EQ(r.exit_code, client::kBotLostStamps) << r.output;
  EXPECT_NE(r.output.find("stamps refused"), std::string::npos) << r.output;
}

TEST(BotExit, ExitsWithLostStampsWhenTheServerGoesAway) {
  ServerProcess server;
  ASSERT_TRUE(server.start(temp_data_dir("bot_exit_gone"))) << server.log();
  Ran r;
  std::thread bot([&] { r = run_bot(server.port(), 200, 20); });  // 10 s of stamps
  std::this_thread::sleep_for(std::chrono::seconds(2));
  server.kill9();
  bot.join();
  EXPECT_EQ(r.exit_code, client::kBotLostStamps) << r.output;
}

#endif

}  // namespace
}  // namespace loam::test
