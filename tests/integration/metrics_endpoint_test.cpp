// `--metrics-bind`: a live server answers GET /metrics with its Prometheus text, counting what
// its clients did, and anything else with 404.
#include <gtest/gtest.h>

#include <string>

#include "integration_util.h"
#include "metrics_scrape.h"
#include "server_process.h"

namespace loam::test {
namespace {

using namespace std::chrono_literals;

TEST(MetricsEndpoint, ServesThePrometheusTextOfALiveServer) {
  ServerProcess server;
  ASSERT_TRUE(server.start(temp_data_dir("metrics"), {"--metrics-bind", "127.0.0.1:0"})) << server.log();
  const uint16_t port = metrics_port(server);
  ASSERT_GT(port, 0) << server.log();
  client::TerrainClient c;
  ASSERT_TRUE(c.connect("127.0.0.1", server.port(), "m").ok());
  StampRng rng(5);
  uint32_t last = 0;
  for (int i = 0; i < 4; ++i) last = *c.deform(random_stamp(rng, c.welcome().world));
  ASSERT_TRUE(c.wait_until([&] { return c.ack(last).has_value(); }, 20s));
  const std::string r = http_get(port, "/metrics");
  ASSERT_EQ(r.rfind("HTTP/1.0 200 OK\r\n", 0), 0u) << r;
  EXPECT_NE(r.find("Content-Type: text/plain; version=0.0.4"), std::string::npos) << r;
  EXPECT_NE(r.find("\nloam_clients 1\n"), std::string::npos) << r;
  EXPECT_NE(r.find("\nloam_deforms_accepted_total 4\n"), std::string::npos) << r;
  EXPECT_NE(r.find("\nloam_tick_seconds_count "), std::string::npos) << r;
  EXPECT_EQ(http_get(port, "/").rfind("HTTP/1.0 404", 0), 0u);
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

TEST(MetricsEndpoint, ABadBindAddressStopsTheServerAtStart) {
  ServerProcess server;
  EXPECT_FALSE(server.start(temp_data_dir("metrics_bad"), {"--metrics-bind", "no-port"}, 10s));
  EXPECT_NE(server.log().find("--metrics-bind"), std::string::npos) << server.log();
}

}  // namespace
}  // namespace loam::test
