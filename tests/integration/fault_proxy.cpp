#include "fault_proxy.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <deque>
#include <memory>
#include <vector>

namespace loam::test {

namespace {

using Clock = std::chrono::steady_clock;

int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count();
}

void set_nonblocking(int fd) { ::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL, 0) | O_NONBLOCK); }

// Bytes read from one end, to be written to the other at `due`.
struct Chunk {
  int64_t due_ns = 0;
  std::vector<uint8_t> bytes;
  size_t written = 0;
};

// Where a direction's byte stream is in its frames (6-byte header: u32 payload length, u16
// type), to cut one whole frame out of it.
struct FrameCursor {
  uint8_t header[6] = {};
  size_t have = 0;    // header bytes seen of the current frame
  uint64_t left = 0;  // payload bytes still to come of the current frame
  bool drop = false;  // the current frame is being cut out
};

struct Direction {
  int from = -1, to = -1;
  std::deque<Chunk> queue;
  int64_t last_due_ns = 0;  // dues never go backwards: order is kept
  bool from_closed = false;
  bool upstream = false;  // client -> server
  FrameCursor frames;
};

// The bytes of `in` that go on, without the frame of type `drop_type` when one is asked for
// (drop_type is then cleared and `dropped` counted).
std::vector<uint8_t> cut_frames(FrameCursor& f, const uint8_t* in, size_t n, std::atomic<uint16_t>& drop_type,
                                std::atomic<uint64_t>& dropped) {
  std::vector<uint8_t> out;
  out.reserve(n);
  size_t i = 0;
  while (i < n) {
    if (f.left == 0) {  // in a header
      f.header[f.have++] = in[i++];
      if (f.have < 6) continue;
      const uint64_t length = uint64_t(f.header[0]) | uint64_t(f.header[1]) << 8 |
                              uint64_t(f.header[2]) << 16 | uint64_t(f.header[3]) << 24;
      const uint16_t type = uint16_t(f.header[4] | f.header[5] << 8);
      uint16_t want = type;
      f.drop = type != 0 && drop_type.compare_exchange_strong(want, 0);
      if (f.drop) ++dropped;
      if (!f.drop) out.insert(out.end(), f.header, f.header + 6);
      f.left = length;
      f.have = 0;
      continue;
    }
    const size_t take = size_t(std::min<uint64_t>(f.left, n - i));
    if (!f.drop) out.insert(out.end(), in + i, in + i + take);
    i += take;
    f.left -= take;
  }
  return out;
}

struct Link {
  int client = -1, server = -1;
  Direction up, down;  // client -> server, server -> client
  bool dead = false;
};

void hard_close(int fd) {
  if (fd < 0) return;
  linger l{1, 0};  // close with RST
  ::setsockopt(fd, SOL_SOCKET, SO_LINGER, &l, sizeof l);
  ::close(fd);
}

}  // namespace

FaultProxy::FaultProxy(uint16_t upstream_port, Faults faults, uint64_t seed)
    : upstream_(upstream_port), faults_(faults), rng_(seed * 2654435761u + 1) {
  listen_fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
  int one = 1;
  ::setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  ::bind(listen_fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);
  ::listen(listen_fd_, 64);
  socklen_t len = sizeof addr;
  ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &len);
  port_ = ntohs(addr.sin_port);
  set_nonblocking(listen_fd_);
  thread_ = std::thread([this] { run(); });
}

FaultProxy::~FaultProxy() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
  ::close(listen_fd_);
}

void FaultProxy::stall(std::chrono::milliseconds d) {
  stall_until_ns_.store(now_ns() + std::chrono::duration_cast<std::chrono::nanoseconds>(d).count());
}

std::vector<uint8_t> FaultProxy::client_bytes() const {
  std::lock_guard lock(sent_mutex_);
  return sent_;
}

void FaultProxy::run() {
  std::vector<std::unique_ptr<Link>> links;
  std::vector<uint8_t> buf(65536);
  auto draw_delay_ns = [&]() -> int64_t {
    rng_ = rng_ * 6364136223846793005ull + 1442695040888963407ull;
    const int64_t jitter_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(faults_.jitter).count();
    const int64_t extra = jitter_ns > 0 ? int64_t((rng_ >> 33) % uint64_t(jitter_ns + 1)) : 0;
    return std::chrono::duration_cast<std::chrono::nanoseconds>(faults_.delay).count() + extra;
  };
  while (!stop_.load()) {
    if (reset_.exchange(false)) {
      for (auto& l : links) {
        hard_close(l->client);
        hard_close(l->server);
        l->client = l->server = -1;
        l->dead = true;
      }
    }
    for (auto& l : links) {
      if (l->dead && l->client >= 0) {
        ::close(l->client);
        ::close(l->server);
        l->client = l->server = -1;
      }
    }
    links.erase(std::remove_if(links.begin(), links.end(), [](const auto& l) { return l->dead; }),
                links.end());
    // New clients: each gets its own upstream connection.
    for (;;) {
      const int c = ::accept(listen_fd_, nullptr, nullptr);
      if (c < 0) break;
      const int s = ::socket(AF_INET, SOCK_STREAM, 0);
      sockaddr_in addr{};
      addr.sin_family = AF_INET;
      addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
      addr.sin_port = htons(upstream_);
      if (::connect(s, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
        ::close(s);
        hard_close(c);
        continue;
      }
      int one = 1;
      ::setsockopt(c, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
      ::setsockopt(s, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
      set_nonblocking(c);
      set_nonblocking(s);
      auto l = std::make_unique<Link>();
      l->client = c;
      l->server = s;
      l->up.from = c, l->up.to = s;
      l->up.upstream = true;
      l->down.from = s, l->down.to = c;
      links.push_back(std::move(l));
      ++connections_;
    }
    const int64_t now = now_ns();
    const bool stalled = now < stall_until_ns_.load();
    int64_t next_due = now + 10'000'000;  // poll at least every 10 ms (accepts, resets)
    std::vector<pollfd> fds;
    std::vector<Direction*> readers;
    for (auto& l : links) {
      for (Direction* d : {&l->up, &l->down}) {
        // Write what is due, unless the link is stalled.
        while (!stalled && !d->queue.empty() && d->queue.front().due_ns <= now) {
          Chunk& ch = d->queue.front();
          const ssize_t n =
              ::send(d->to, ch.bytes.data() + ch.written, ch.bytes.size() - ch.written, MSG_NOSIGNAL);
          if (n <= 0) break;
          ch.written += size_t(n);
          forwarded_ += uint64_t(n);
          if (ch.written == ch.bytes.size()) d->queue.pop_front();
        }
        if (!d->queue.empty())
          next_due = std::min(next_due, std::max(d->queue.front().due_ns, now + 1'000'000));
        // The other end closed and everything it sent is through: pass the close on.
        if (d->from_closed && d->queue.empty()) l->dead = true;
        if (!d->from_closed) {
          fds.push_back({d->from, POLLIN, 0});
          readers.push_back(d);
        }
      }
    }
    const int timeout_ms = int(std::max<int64_t>(0, (next_due - now) / 1'000'000));
    if (::poll(fds.data(), fds.size(), std::min(timeout_ms, 10)) <= 0) continue;
    for (size_t i = 0; i < fds.size(); ++i) {
      if (!(fds[i].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      Direction* d = readers[i];
      const ssize_t n = ::recv(d->from, buf.data(), buf.size(), 0);
      if (n <= 0) {
        if (n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK)) d->from_closed = true;
        continue;
      }
      const int64_t due = std::max(now_ns() + draw_delay_ns(), d->last_due_ns);
      d->last_due_ns = due;
      std::vector<uint8_t> bytes = d->upstream
                                       ? std::vector<uint8_t>(buf.begin(), buf.begin() + n)
                                       : cut_frames(d->frames, buf.data(), size_t(n), drop_type_, dropped_);
      if (!bytes.empty()) d->queue.push_back({due, std::move(bytes), 0});
      if (d->upstream) {
        std::lock_guard lock(sent_mutex_);
        const size_t keep = std::min(size_t(n), kSentKept - std::min(kSentKept, sent_.size()));
        sent_.insert(sent_.end(), buf.begin(), buf.begin() + ptrdiff_t(keep));
      }
    }
  }
  for (auto& l : links) {
    if (l->client >= 0) {
      ::close(l->client);
      ::close(l->server);
    }
  }
}

}  // namespace loam::test
