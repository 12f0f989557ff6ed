// The idle timeout counts complete frames only: a session kept alive by a byte now and then of
// a frame it never finishes (slowloris) is closed, while a quiet client that pings stays.
#include <gtest/gtest.h>

#include <chrono>

#include "integration_util.h"
#include "server_process.h"

namespace loam::test {
namespace {

using namespace std::chrono_literals;

// Sends `bytes` one at a time, every `every`, reading meanwhile; how long the server kept the
// connection open, or nullopt when it never closed it.
std::optional<std::chrono::duration<double>> seconds_until_closed(client::Connection& c,
                                                                  const std::vector<uint8_t>& bytes,
                                                                  std::chrono::milliseconds every) {
  const auto start = std::chrono::steady_clock::now();
  for (const uint8_t b : bytes) {
    c.send_raw({b});
    const auto until = std::chrono::steady_clock::now() + every;
    while (std::chrono::steady_clock::now() < until) {
      if (!c.next(20ms)) return std::chrono::steady_clock::now() - start;  // closed
    }
  }
  return std::nullopt;
}

TEST(IdleTimeout, AFrameNeverFinishedDoesNotKeepASessionAlive) {
  ServerProcess server;
  ASSERT_TRUE(server.start(temp_data_dir("slowloris"), {"--idle-timeout", "1"})) << server.log();
  client::Connection c;
  wire::Hello h;
  h.client_name = "slow";
  ASSERT_TRUE(c.connect("127.0.0.1", server.port(), h).ok());
  // A large valid frame, of which only the first 16 bytes go, one every 250 ms (4 s in all).
  wire::Subscribe sub;
  for (int32_t i = 0; i < 64; ++i)
    sub.entries.push_back({TileCoord{Layer::kCoarse, 0, i % 4, i / 4 % 3}, false, 0});
  auto frame = wire::encode_frame(sub);
  ASSERT_TRUE(frame.ok());
  const std::vector<uint8_t> head(frame->begin(), frame->begin() + 16);
  const auto closed = seconds_until_closed(c, head, 250ms);
  ASSERT_TRUE(closed.has_value()) << "a never-finished frame kept the session for 4 s";
  EXPECT_LT(closed->count(), 3.0);
  EXPECT_NE(server.log().find("idle"), std::string::npos) << server.log();
}

TEST(IdleTimeout, CompleteFramesKeepAQuietClientConnected) {
  ServerProcess server;
  ASSERT_TRUE(server.start(temp_data_dir("pinger"), {"--idle-timeout", "1"})) << server.log();
  client::Connection c;
  wire::Hello h;
  h.client_name = "pinger";
  ASSERT_TRUE(c.connect("127.0.0.1", server.port(), h).ok());
  auto ping = wire::encode_frame(wire::Ping{7});
  ASSERT_TRUE(ping.ok());
  // Eight whole pings, 400 ms apart: 3.2 s, over three timeouts.
  for (int i = 0; i < 8; ++i) {
    c.send_raw(*ping);
    const auto until = std::chrono::steady_clock::now() + 400ms;
    while (std::chrono::steady_clock::now() < until)
      ASSERT_TRUE(c.next(20ms)) << "closed after " << i << " pings";
  }
}

}  // namespace
}  // namespace loam::test
