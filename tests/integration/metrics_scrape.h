// Reading a live server's /metrics in a test: the port its log names, and one HTTP/1.0 GET.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <string>

#include "server_process.h"

namespace loam::test {

// One HTTP/1.0 request to 127.0.0.1:port; the whole response.
inline std::string http_get(uint16_t port, const std::string& target) {
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

// The metrics port the server's `metrics_listening` line reports (bound to any free one); 0
// when there is none.
inline uint16_t metrics_port(const ServerProcess& server) {
  const std::string log = server.log();
  const size_t line = log.find("event=metrics_listening");
  if (line == std::string::npos) return 0;
  const size_t at = log.find(" port=", line);
  if (at == std::string::npos) return 0;
  return uint16_t(std::stoi(log.substr(at + 6)));
}

inline std::string http_get_metrics(const ServerProcess& server) {
  return http_get(metrics_port(server), "/metrics");
}

}  // namespace loam::test
