// Clients on a bad network (fault_proxy.h between them and the server): delay, jitter and a
// link that stalls for seconds lose no edits and leave every client converged; after a reset
// the bot and a viewer reconnect and resume, and every stamp counts exactly once.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "client/bot.h"
#include "fault_proxy.h"
#include "integration_util.h"
#include "program_run.h"
#include "server_process.h"

namespace loam::test {
namespace {

using namespace std::chrono_literals;

#ifdef LOAM_CLIENT_BINARY

Ran run_bot(uint16_t port, const std::string& name, int seed, int stamps) {
  return run({LOAM_CLIENT_BINARY, "bot", "--port", std::to_string(port), "--name", name, "--seed",
              std::to_string(seed), "--stamps", std::to_string(stamps), "--rate", "20"});
}

// A spectator holding every mip-0 tile, through `port`.
bool join_as_viewer(client::TerrainClient& viewer, uint16_t port) {
  return viewer.connect("127.0.0.1", port, "viewer", wire::Role::kSpectator).ok() &&
         viewer.subscribe(viewer.all_coarse_tiles(0)).ok();
}

// Pumps `c` for `d`.
void pump_for(client::TerrainClient& c, std::chrono::milliseconds d) {
  const auto until = std::chrono::steady_clock::now() + d;
  while (std::chrono::steady_clock::now() < until) (void)c.pump(20ms);
}

TEST(NetworkFaults, BotsAndAViewerConvergeThroughDelayJitterAndAStalledLink) {
  const std::string dir = temp_data_dir("faults");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir)) << server.log();
  FaultProxy proxy(server.port(), {40ms, 30ms}, 7);
  client::TerrainClient viewer;
  ASSERT_TRUE(join_as_viewer(viewer, proxy.port()));
  Ran a, b;
  std::thread ta([&] { a = run_bot(proxy.port(), "a", 1, 60); });
  std::thread tb([&] { b = run_bot(proxy.port(), "b", 2, 60); });
  pump_for(viewer, 1000ms);
  proxy.stall(2000ms);  // the link drops out for two seconds; the backlog then arrives at once
  pump_for(viewer, 2500ms);
  ta.join();
  tb.join();
  // Every stamp accepted and every hash agreed, in each bot's own judgement.
  EXPECT_EQ(a.exit_code, client::kBotOk) << a.output;
  EXPECT_EQ(b.exit_code, client::kBotOk) << b.output;
  EXPECT_NE(a.output.find("60/60 stamps accepted"), std::string::npos) << a.output;
  EXPECT_NE(b.output.find("60/60 stamps accepted"), std::string::npos) << b.output;
  // The viewer holds exactly what the log replays to.
  ASSERT_TRUE(viewer.wait_until([&] { return viewer.last_event_seq() >= 120; }, 30s)) << server.log();
  const World expected = replayed_world(dir, 120);
  EXPECT_TRUE(viewer.wait_until([&] { return bool(store_matches(viewer, expected)); }, 30s))
      << store_matches(viewer, expected).message();
  EXPECT_GT(proxy.bytes_forwarded(), 0u);
}

TEST(NetworkFaults, AfterAResetTheBotAndTheViewerReconnectAndEveryStampCountsOnce) {
  const std::string dir = temp_data_dir("reset");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir)) << server.log();
  FaultProxy proxy(server.port(), {5ms, 5ms}, 3);
  client::TerrainClient viewer;
  ASSERT_TRUE(join_as_viewer(viewer, proxy.port()));
  Ran bot;
  std::thread t([&] { bot = run_bot(proxy.port(), "r", 3, 100); });  // five seconds of stamps
  pump_for(viewer, 1500ms);
  proxy.reset_all();  // both lose their connection mid-stream
  pump_for(viewer, 300ms);
  // The viewer reconnects through the same proxy and resumes from the versions it holds.
  ASSERT_TRUE(viewer.reconnect("127.0.0.1", proxy.port()).ok());
  t.join();
  // The bot reconnected, resent what was unanswered, and every stamp was accepted once.
  EXPECT_EQ(bot.exit_code, client::kBotOk) << bot.output;
  EXPECT_NE(bot.output.find("100/100 stamps accepted"), std::string::npos) << bot.output;
  EXPECT_NE(bot.output.find("reconnected"), std::string::npos) << bot.output;
  client::TerrainClient probe;
  ASSERT_TRUE(probe.connect("127.0.0.1", server.port(), "probe", wire::Role::kSpectator).ok());
  EXPECT_EQ(probe.welcome().global_sequence, 100u) << "a resent stamp was applied twice";
  // And the viewer holds what the log replays to.
  ASSERT_TRUE(viewer.wait_until([&] { return viewer.last_event_seq() >= 100; }, 30s)) << server.log();
  const World expected = replayed_world(dir, 100);
  EXPECT_TRUE(viewer.wait_until([&] { return bool(store_matches(viewer, expected)); }, 30s))
      << store_matches(viewer, expected).message();
  EXPECT_GE(proxy.connections(), 4u);
}

#endif

}  // namespace
}  // namespace loam::test
