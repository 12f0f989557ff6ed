// `--metrics-bind`: a live server answers GET /metrics with its Prometheus text, counting what
// its clients did, and anything else with 404.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <string>

#include "integration_util.h"
#include "server_process.h"

namespace loam::test {
namespace {

using namespace std::chrono_literals;

// One HTTP/1.0 request to 127.0.0.1:port; the whole response.
std::string http_get(uint16_t port, const std::string& target) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return {};
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(port);
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  std::string response;
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) == 0) {
    const std::string request = "GET " + target + " HTTP/1.0\r\nHost: localhost\r\n\r\n";
    if (::send(fd, request.data(), request.size(), 0) == ssize_t(request.size())) {
      char buf[4096];
      ssize_t n;
      while ((n = ::recv(fd, buf, sizeof buf, 0)) > 0) response.append(buf, size_t(n));
    }
  }
  ::close(fd);
  return response;
}

TEST(MetricsEndpoint, ServesThePrometheusTextOfALiveServer) {
  ServerProcess server;
  ASSERT_TRUE(server.start(temp_data_dir("metrics"), {"--metrics-bind", "127.0.0.1:0"})) << server.log();
  // The port the log line reports (bound to any free one).
  const std::string log = server.log();
  const size_t line = log.find("event=metrics_listening");
  ASSERT_NE(line, std::string::npos) << log;
  const size_t at = log.find(" port=", line);
  ASSERT_NE(at, std::string::npos) << log;
  const uint16_t port = uint16_t(std::stoi(log.substr(at + 6)));
  ASSERT_GT(port, 0);
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
