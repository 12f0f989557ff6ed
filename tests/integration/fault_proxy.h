// A TCP proxy between clients and a server that injects network faults, for tests (this
// kernel has no netem): a delay with jitter on every byte (order kept), a stall (nothing
// forwarded for a while, as a link that drops out and comes back: the bytes wait and then
// arrive at once), a reset of every connection (RST both ways), and the loss of one whole
// server-to-client frame of a given message type (plain TCP only: it reads the frame
// headers, so it cannot see inside TLS). One thread polls every
// link; faults are asked for from the test's thread. It also keeps the first bytes clients
// sent, for tests of what crosses the wire.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

namespace loam::test {

class FaultProxy {
 public:
  struct Faults {
    std::chrono::milliseconds delay{0};   // added to every byte, each direction
    std::chrono::milliseconds jitter{0};  // plus up to this much more, drawn per read
  };
  // Listens on an ephemeral loopback port and forwards to 127.0.0.1:upstream_port.
  FaultProxy(uint16_t upstream_port, Faults faults, uint64_t seed = 1);
  ~FaultProxy();
  FaultProxy(const FaultProxy&) = delete;
  FaultProxy& operator=(const FaultProxy&) = delete;

  uint16_t port() const { return port_; }
  // Nothing is forwarded either way for `d` from now; what arrives meanwhile waits.
  void stall(std::chrono::milliseconds d);
  // Every open connection is reset (RST to both ends); new connections are accepted.
  void reset_all() { reset_.store(true); }
  // The next server-to-client frame of this message type (wire::MessageType), on any
  // connection, is cut out of the stream whole: the client never sees it and every other
  // frame arrives intact. The frames before and after it keep their order.
  void drop_next_frame_to_client(uint16_t type) { drop_type_.store(type); }
  uint64_t frames_dropped() const { return dropped_.load(); }
  uint64_t bytes_forwarded() const { return forwarded_.load(); }
  uint64_t connections() const { return connections_.load(); }
  // The first kSentKept bytes the clients sent, all connections in arrival order.
  std::vector<uint8_t> client_bytes() const;
  static constexpr size_t kSentKept = 1 << 20;

 private:
  void run();

  uint16_t upstream_;
  Faults faults_;
  uint64_t rng_;
  int listen_fd_ = -1;
  uint16_t port_ = 0;
  std::atomic<bool> stop_{false}, reset_{false};
  std::atomic<int64_t> stall_until_ns_{0};
  std::atomic<uint64_t> forwarded_{0}, connections_{0};
  std::atomic<uint16_t> drop_type_{0};  // 0: none asked for
  std::atomic<uint64_t> dropped_{0};
  mutable std::mutex sent_mutex_;
  std::vector<uint8_t> sent_;
  std::thread thread_;
};

}  // namespace loam::test
