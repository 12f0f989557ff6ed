// Suite `fairness`: can one client stall the others? A real loam-server process on the
// embedded crop, and a canary player sending small craters (5 a second, Poisson) while each
// attack runs from threads of this process:
//  - shockwave: a player sending the largest shockwave the stamp limits allow (radius 1000
//    samples, 1024 steps: refused by cost) and the costliest one admitted, back to back;
//  - detail: a player sending whole-layer detail stamps at the allowed 60 a second;
//  - spectators: 20 spectators subscribing and unsubscribing every tile of the world in a loop;
//  - slowloris: 64 connections that send one byte of a frame and then a byte every 2 s,
//    reopened as the server closes them;
//  - churn: connect and close, as fast as one thread can.
// Per phase: the canary's ack latency (send to Ack) against its quiet baseline, the bound being
// 2 ticks above the baseline's p99; its stamps refused; how long a new client takes to join
// while the attack runs; what the attack achieved; the server's CPU use and RSS. Server, canary
// and attackers share this machine's cores; the attack threads run at the lowest priority (as
// attackers elsewhere would not take the server's CPU), so what is measured is what the
// attack's traffic costs the server.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <filesystem>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "bench/harness.h"
#include "bench/server_stats.h"
#include "client/net/terrain_client.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_validate.h"
#include "server/server_config.h"
#include "tests/integration/server_process.h"

namespace loam::bench {
namespace {

using clock_type = std::chrono::steady_clock;
using namespace std::chrono_literals;

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[size_t(p * double(v.size() - 1))];
}

// /proc/<pid>/status fields in MiB: VmRSS (now) and VmHWM (peak).
double proc_status_mib(pid_t pid, const char* field) {
  std::FILE* f = std::fopen(("/proc/" + std::to_string(pid) + "/status").c_str(), "r");
  if (!f) return 0;
  char line[256];
  double kib = 0;
  const std::string want = std::string(field) + ": %lf kB";
  while (std::fgets(line, sizeof line, f))
    if (std::sscanf(line, want.c_str(), &kib) == 1) break;
  std::fclose(f);
  return kib / 1024.0;
}

// CPU seconds a process has used (user + system), from /proc/<pid>/stat.
double proc_cpu_seconds(pid_t pid) {
  std::FILE* f = std::fopen(("/proc/" + std::to_string(pid) + "/stat").c_str(), "r");
  if (!f) return 0;
  char buf[1024];
  const size_t n = std::fread(buf, 1, sizeof buf - 1, f);
  std::fclose(f);
  buf[n] = 0;
  // Fields after the command (which may hold spaces): state is field 3, utime 14, stime 15.
  const char* p = std::strrchr(buf, ')');
  unsigned long long utime = 0, stime = 0;
  if (!p || std::sscanf(p + 2, "%*c %*d %*d %*d %*d %*d %*u %*u %*u %*u %*u %llu %llu", &utime, &stime) != 2)
    return 0;
  return double(utime + stime) / double(::sysconf(_SC_CLK_TCK));
}

// Every attack thread runs at the lowest priority: on a network the attackers' own CPU is
// theirs, here it is this machine's two hardware threads, and a client decoding regions in 20
// threads would otherwise measure the scheduler rather than the server.
void attacker_priority() { ::setpriority(PRIO_PROCESS, pid_t(::syscall(SYS_gettid)), 19); }

std::optional<QuantizedStamp> quantize(const StampParams& s, const WorldParams& w) {
  auto q = validate_stamp(s, w, StampLimits{});
  if (!q) return std::nullopt;
  return *q;
}

// What an attack did, in its own words (one cell of the table).
struct AttackOutcome {
  std::atomic<uint64_t> sent{0}, accepted{0}, refused{0}, connections{0}, closed_by_server{0}, errors{0};
};

// The canary: small craters at random places, Poisson at `rate` a second, for `seconds`.
struct CanaryRun {
  std::vector<double> ack_ms;
  size_t refused = 0, unanswered = 0;
  bool lost = false;
};

CanaryRun run_canary(client::TerrainClient& c, std::mt19937& rng, double rate, double seconds) {
  CanaryRun r;
  const WorldParams& w = c.welcome().world;
  const RectI s = w.sample_rect();
  std::uniform_real_distribution<double> ux(double(s.x0) + 40, double(s.x1) - 40);
  std::uniform_real_distribution<double> uy(double(s.y0) + 40, double(s.y1) - 40);
  std::exponential_distribution<double> gap(rate);
  struct Out {
    uint32_t seq;
    clock_type::time_point at;
  };
  std::deque<Out> outstanding;
  const auto collect = [&] {
    while (!outstanding.empty()) {
      const auto a = c.ack(outstanding.front().seq);
      if (!a) break;
      r.ack_ms.push_back(ms_since(outstanding.front().at));
      if (!a->accepted) ++r.refused;
      outstanding.pop_front();
    }
  };
  const auto start = clock_type::now();
  const auto end =
      start + std::chrono::duration_cast<clock_type::duration>(std::chrono::duration<double>(seconds));
  auto next = start;
  while (clock_type::now() < end) {
    if (clock_type::now() >= next) {
      StampParams p;
      p.kind = StampKind::kCrater;
      p.center_x = ux(rng) * w.meters_per_sample;
      p.center_y = uy(rng) * w.meters_per_sample;
      p.radius = 5.0 * w.meters_per_sample;
      p.intensity = 0.5;
      p.shape = 0.3;
      if (auto q = quantize(p, w)) {
        if (auto seq = c.deform(*q)) outstanding.push_back({*seq, clock_type::now()});
      }
      next += std::chrono::duration_cast<clock_type::duration>(std::chrono::duration<double>(gap(rng)));
    }
    if (!c.pump(1ms).ok()) {
      r.lost = true;
      return r;
    }
    collect();
  }
  const auto deadline = clock_type::now() + 20s;
  while (!outstanding.empty() && clock_type::now() < deadline) {
    if (!c.pump(2ms).ok()) break;
    collect();
  }
  r.unanswered = outstanding.size();
  return r;
}

// A player sending `stamps` in turn as fast as its client lets it (the client paces to the
// announced limits), reading what comes back.
void stamp_attacker(uint16_t port, const std::vector<QuantizedStamp>& stamps, const std::atomic<bool>& stop,
                    AttackOutcome& out, const char* name) {
  attacker_priority();
  if (stamps.empty()) {
    ++out.errors;
    return;
  }
  client::TerrainClient c;
  if (!c.connect("127.0.0.1", port, name).ok()) {
    ++out.errors;
    return;
  }
  std::deque<uint32_t> outstanding;
  size_t i = 0;
  while (!stop) {
    if (c.deforms_queued() < 4) {
      if (auto seq = c.deform(stamps[i++ % stamps.size()])) {
        outstanding.push_back(*seq);
        ++out.sent;
      }
    }
    if (!c.pump(1ms).ok()) {
      ++out.errors;
      return;
    }
    while (!outstanding.empty()) {
      const auto a = c.ack(outstanding.front());
      if (!a) break;
      ++(a->accepted ? out.accepted : out.refused);
      outstanding.pop_front();
    }
  }
}

// A spectator subscribing and unsubscribing `tiles` in a loop, reading what comes back.
void resubscriber(uint16_t port, const std::atomic<bool>& stop, AttackOutcome& out, int index) {
  attacker_priority();
  client::TerrainClient c;
  if (!c.connect("127.0.0.1", port, "spectator" + std::to_string(index), wire::Role::kSpectator).ok()) {
    ++out.errors;
    return;
  }
  std::vector<TileCoord> tiles;
  const WorldParams& w = c.welcome().world;
  for (int32_t m = 0; m < w.mip_count(); ++m) {
    const auto t = c.all_coarse_tiles(m);
    tiles.insert(tiles.end(), t.begin(), t.end());
  }
  const RectI d = tiles_overlapping(w.detail_sample_rect());
  for (int64_t ty = d.y0; ty < d.y1; ++ty)
    for (int64_t tx = d.x0; tx < d.x1; ++tx) tiles.push_back({Layer::kDetail, 0, int32_t(tx), int32_t(ty)});
  // As fast as the socket takes them: the next pair once the last one's bytes start to leave
  // (the client's writes are queued, so an unchecked loop would only grow its own queue).
  uint64_t written = 0;
  bool first = true;
  while (!stop) {
    if (first || c.connection().bytes_out() > written) {
      first = false;
      written = c.connection().bytes_out();
      if (!c.subscribe(tiles).ok() || !c.unsubscribe(tiles).ok()) {
        ++out.closed_by_server;
        return;
      }
      out.sent += 2;
    }
    if (!c.pump(1ms).ok()) {
      ++out.closed_by_server;
      return;
    }
  }
  out.refused += c.errors().size();
}

// A TCP connection to the server from 127.0.0.2: the attacker's own address, as it would be
// on a network (the canary and the joiner connect from 127.0.0.1, and the server limits
// handshakes per address).
int open_socket(uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  sockaddr_in from{};
  from.sin_family = AF_INET;
  from.sin_addr.s_addr = htonl(INADDR_LOOPBACK + 1);
  if (::bind(fd, reinterpret_cast<const sockaddr*>(&from), sizeof from) != 0) {
    ::close(fd);
    return -1;
  }
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// `pool` connections, each sending a byte of a frame header and then a byte every 2 s; a
// connection the server closed (a failed send) is reopened.
void slowloris(uint16_t port, size_t pool, const std::atomic<bool>& stop, AttackOutcome& out) {
  attacker_priority();
  std::vector<int> fds(pool, -1);
  auto next_byte = clock_type::now();
  while (!stop) {
    for (int& fd : fds) {
      if (fd >= 0) continue;
      fd = open_socket(port);
      if (fd < 0) continue;
      ++out.connections;
      const uint8_t b = 0x4c;
      (void)::send(fd, &b, 1, MSG_NOSIGNAL);
    }
    if (clock_type::now() >= next_byte) {
      next_byte += 2s;
      for (int& fd : fds) {
        const uint8_t b = 0;
        if (fd >= 0 && ::send(fd, &b, 1, MSG_NOSIGNAL) != 1) {
          ::close(fd);
          fd = -1;
          ++out.closed_by_server;
        }
      }
    }
    std::this_thread::sleep_for(50ms);
  }
  for (int fd : fds)
    if (fd >= 0) ::close(fd);
}

void churn(uint16_t port, const std::atomic<bool>& stop, AttackOutcome& out) {
  attacker_priority();
  while (!stop) {
    const int fd = open_socket(port);
    if (fd < 0) {
      ++out.errors;
      continue;
    }
    ++out.connections;
    // Reset, not a FIN: no TIME_WAIT left behind, so the loop never runs out of ports.
    const linger l{1, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_LINGER, &l, sizeof l);
    ::close(fd);
  }
}

struct Phase {
  std::string name, attack;
  // Starts the attack's threads; they run until `stop`.
  std::function<void(std::vector<std::thread>&, const std::atomic<bool>&, AttackOutcome&)> start;
  std::function<std::string(const AttackOutcome&, double seconds)> describe;
};

int run_fairness(const Context& ctx, Report& report) {
#ifndef LOAM_SERVER_BINARY
  report.paragraph("Skipped: built without the server.");
  return 0;
#else
  namespace fs = std::filesystem;
  const double phase_s = ctx.quick ? 3.0 : 20.0, canary_rate = 5.0;
  const server::ServerConfig defaults;
  const double tick_ms = 1000.0 / double(defaults.tick_hz);
  const std::string dir =
      (fs::temp_directory_path() / ("loam_bench_fairness_" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  test::ServerProcess server;
  // The default byte budget per client (the test harness turns it off unless told).
  // LOAM_FAIRNESS_BACKEND=gpu runs the server's stamps on the GPU backend (default: cpu).
  const char* backend_env = std::getenv("LOAM_FAIRNESS_BACKEND");
  const std::string backend = backend_env ? backend_env : defaults.backend;
  if (!server.start(dir, {"--terrain", "crop", "--client-budget",
                          std::to_string(defaults.client_bytes_per_second), "--backend", backend})) {
    std::printf("fairness: the server did not start: %s\n", server.log().c_str());
    return 1;
  }
  const uint16_t port = server.port();
  client::TerrainClient canary;
  if (!canary.connect("127.0.0.1", port, "canary").ok()) {
    std::printf("fairness: the canary could not connect\n");
    return 1;
  }
  const WorldParams w = canary.welcome().world;
  const double cx = double(w.sample_rect().x0 + w.sample_rect().x1) / 2 * w.meters_per_sample;
  const double cy = double(w.sample_rect().y0 + w.sample_rect().y1) / 2 * w.meters_per_sample;

  // The shockwaves: the (radius 1000 samples, 1024 steps; far over the cost cap) and
  // the costliest the cost cap admits (steps halved until it fits).
  std::vector<QuantizedStamp> shockwaves;
  std::string admitted_shockwave = "none";
  {
    StampParams p;
    p.kind = StampKind::kShockwave;
    p.layer = Layer::kDetail;
    p.center_x = cx, p.center_y = cy;
    p.radius = 1000.0 * w.detail_meters_per_sample();
    p.intensity = 0.5;
    p.speed = 0.5;
    p.damping = 0.01;
    p.steps = 1024;
    if (auto q = quantize(p, w)) shockwaves.push_back(*q);
    p.radius = 64.0 * w.detail_meters_per_sample();
    for (uint32_t steps = 1024; steps >= 1; steps /= 2) {
      p.steps = steps;
      auto q = quantize(p, w);
      if (!q) continue;
      const auto cost = stamp_cost(*q, w);
      if (cost && *cost <= defaults.max_stamp_cost) {
        shockwaves.push_back(*q);
        admitted_shockwave =
            "radius 64 detail samples, " + std::to_string(steps) + " steps, cost " + std::to_string(*cost);
        break;
      }
    }
  }
  // A detail stamp over the whole detail layer.
  std::vector<QuantizedStamp> detail;
  {
    StampParams p;
    p.kind = StampKind::kGaussian;
    p.layer = Layer::kDetail;
    p.center_x = cx, p.center_y = cy;
    const RectI d = w.detail_sample_rect();
    p.radius = double(std::max(d.width(), d.height())) * w.detail_meters_per_sample() / 2.0 * 1.42;
    p.intensity = 0.01;
    if (auto q = quantize(p, w)) detail.push_back(*q);
  }
  const size_t spectators = 20, slow_pool = 64;
  std::vector<Phase> phases;
  phases.push_back({"quiet", "none", nullptr, nullptr});
  phases.push_back(
      {"shockwave", "the largest shockwave the limits allow (refused by cost) and the costliest admitted",
       [&](std::vector<std::thread>& t, const std::atomic<bool>& stop, AttackOutcome& out) {
         t.emplace_back([&, port] { stamp_attacker(port, shockwaves, stop, out, "shockwaver"); });
       },
       [](const AttackOutcome& o, double) {
         return std::to_string(o.accepted) + " accepted, " + std::to_string(o.refused) + " refused" +
                (o.errors > 0 ? ", " + std::to_string(o.errors) + " errors" : "");
       }});
  phases.push_back({"detail", "whole-layer detail gaussians at the allowed rate",
                    [&](std::vector<std::thread>& t, const std::atomic<bool>& stop, AttackOutcome& out) {
                      t.emplace_back([&, port] { stamp_attacker(port, detail, stop, out, "detailer"); });
                    },
                    [](const AttackOutcome& o, double) {
                      return std::to_string(o.accepted) + " accepted, " + std::to_string(o.refused) +
                             " refused";
                    }});
  phases.push_back({"spectators", std::to_string(spectators) + " spectators re-subscribing every tile",
                    [&](std::vector<std::thread>& t, const std::atomic<bool>& stop, AttackOutcome& out) {
                      for (size_t i = 0; i < spectators; ++i)
                        t.emplace_back([&, port, i] { resubscriber(port, stop, out, int(i)); });
                    },
                    [](const AttackOutcome& o, double s) {
                      return fmt("%.0f requests/s, ", double(o.sent) / s) + std::to_string(o.refused) +
                             " refusals answered, " + std::to_string(o.closed_by_server) + " dropped";
                    }});
  phases.push_back({"slowloris", std::to_string(slow_pool) + " connections trickling a frame",
                    [&](std::vector<std::thread>& t, const std::atomic<bool>& stop, AttackOutcome& out) {
                      t.emplace_back([&, port] { slowloris(port, slow_pool, stop, out); });
                    },
                    [](const AttackOutcome& o, double) {
                      return std::to_string(o.connections) + " opened, " +
                             std::to_string(o.closed_by_server) + " found closed";
                    }});
  phases.push_back({"churn", "connect and close in a loop",
                    [&](std::vector<std::thread>& t, const std::atomic<bool>& stop, AttackOutcome& out) {
                      t.emplace_back([&, port] { churn(port, stop, out); });
                    },
                    [](const AttackOutcome& o, double s) {
                      return fmt("%.0f connections/s", double(o.connections) / s);
                    }});

  Table table("fairness",
              {"phase", "attack", "canary stamps", "ack p50 ms", "ack p99 ms", "bound ms", "within",
               "canary refused", "join during s", "what the attack did", "server CPU %", "server RSS MiB"});
  std::mt19937 rng(17);
  double baseline_p99 = 0;
  int failures = 0;
  // LOAM_FAIRNESS_PHASES=quiet,spectators runs those phases alone (profiling one attack).
  if (const char* only = std::getenv("LOAM_FAIRNESS_PHASES")) {
    const std::string wanted = std::string(",") + only + ",";
    std::erase_if(phases,
                  [&](const Phase& ph) { return wanted.find("," + ph.name + ",") == std::string::npos; });
  }
  for (const Phase& ph : phases) {
    std::atomic<bool> stop{false};
    AttackOutcome out;
    std::vector<std::thread> threads;
    if (ph.start) ph.start(threads, stop, out);
    std::this_thread::sleep_for(ctx.quick ? 300ms : 1s);  // the attack under way
    const double cpu0 = proc_cpu_seconds(server.pid());
    const auto phase_start = clock_type::now();
    // A client joining while the attack runs.
    double join_s = -1;
    std::thread joiner([&] {
      const auto t0 = clock_type::now();
      client::TerrainClient j;
      if (j.connect("127.0.0.1", port, "joiner").ok()) join_s = ms_since(t0) / 1000.0;
    });
    const CanaryRun cr = run_canary(canary, rng, canary_rate, phase_s);
    joiner.join();
    const double server_cpu =
        100.0 * (proc_cpu_seconds(server.pid()) - cpu0) / (ms_since(phase_start) / 1000.0);
    stop = true;
    for (std::thread& t : threads) t.join();
    const double p50 = percentile(cr.ack_ms, 0.5), p99 = percentile(cr.ack_ms, 0.99);
    if (ph.name == "quiet") baseline_p99 = p99;
    const double bound = baseline_p99 + 2 * tick_ms;
    const bool within = !cr.lost && cr.unanswered == 0 && cr.refused == 0 && p99 <= bound && join_s >= 0;
    if (!within && !ctx.quick && !ctx.sanitized) ++failures;
    if (cr.lost || cr.unanswered > 0) {  // the canary must always be answered
      ++failures;
      const std::string log = server.log();
      std::printf("fairness: the canary %s; the server's log ends:\n%s\n",
                  cr.lost ? "lost its connection" : "was not answered",
                  log.substr(log.size() > 3000 ? log.size() - 3000 : 0).c_str());
    }
    const double rss = proc_status_mib(server.pid(), "VmRSS");
    table.add_row({ph.name, ph.attack, std::to_string(cr.ack_ms.size()), fmt("%.1f", p50), fmt("%.1f", p99),
                   fmt("%.1f", bound), within ? "yes" : "NO", std::to_string(cr.refused + cr.unanswered),
                   join_s >= 0 ? fmt("%.3f", join_s) : "failed",
                   ph.describe ? ph.describe(out, phase_s) : "-", fmt("%.1f", server_cpu), fmt("%.0f", rss)});
    std::printf(
        "  %s: canary ack p50 %.1f ms, p99 %.1f ms (bound %.1f), join %.3f s, server CPU %.1f%%, RSS %.0f "
        "MiB\n",
        ph.name.c_str(), p50, p99, bound, join_s, server_cpu, rss);
    // Let what the attack queued drain before the next phase.
    std::this_thread::sleep_for(ctx.quick ? 500ms : 3s);
  }
  const double peak = proc_status_mib(server.pid(), "VmHWM");
  const double rss_bound = double(defaults.cache_mb) + 256.0;
  if (peak > rss_bound && !ctx.sanitized) ++failures;
  const auto st = server_stats(port);
  report.paragraph(
      "A `loam-server serve --terrain crop --backend " + backend +
      "` process (the embedded 2 x 1.5 km crop, default options: " +
      fmt("%.0f", defaults.deforms_per_second) + " deforms/s and " +
      std::to_string(defaults.stamp_cost_per_second) + " sample updates/s per client, " +
      std::to_string(defaults.max_stamp_cost) + " at most per stamp, " +
      std::to_string(defaults.tick_stamp_cost) + " per tick, " + std::to_string(defaults.tick_hz) +
      " ticks/s) and a canary player sending 5 m craters at 5 a second (Poisson) for " +
      fmt("%.0f", phase_s) +
      " s per phase while each attack runs from threads of the bench. The bound is the quiet p99 plus 2 "
      "ticks; "
      "`within` also needs every canary stamp accepted and a new client to join during the attack. The "
      "shockwave attack sends the issue's radius-1000, 1024-step detail shockwave (refused by cost) and the "
      "costliest one admitted (" +
      admitted_shockwave +
      "). Server, canary and attackers share this machine's hardware threads; the attack threads run at "
      "nice 19, standing for attackers on other machines, so the canary measures what the attack's "
      "traffic costs the server rather than the scheduler's share of 20 decoding threads. `server CPU %` "
      "is the server process's use of one hardware thread during the phase.");
  report.table(table);
  report.paragraph("Server peak RSS over the run: " + fmt("%.0f", peak) + " MiB (bound: `--cache-mb` " +
                   std::to_string(defaults.cache_mb) + " + 256 MiB = " + fmt("%.0f", rss_bound) + " MiB). " +
                   (st ? "Server: " + std::to_string(st->deforms_accepted) + " stamps accepted, " +
                             std::to_string(st->deforms_rejected) + " refused, " +
                             std::to_string(st->tick_overruns) + " ticks over their period."
                       : std::string("The server's stats could not be read.")));
  std::printf("  server peak RSS %.0f MiB (bound %.0f)\n", peak, rss_bound);
  server.terminate();
  if (!std::getenv("LOAM_BENCH_KEEP")) fs::remove_all(dir);
  return failures;
#endif
}

LOAM_BENCH_SUITE(fairness,
                 "a canary's ack latency while one client attacks: shockwaves, detail stamps, spectators, "
                 "slowloris, churn",
                 run_fairness);

}  // namespace
}  // namespace loam::bench
