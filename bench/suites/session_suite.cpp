// Suite `session`: a real loam-server process on loopback and C clients, each subscribed to
// the whole world and deforming it at a steady rate as bots do. Per client count:
//  - ack latency: a Deform's send to its Ack (the tick wait, one fsync, the apply);
//  - fan-out latency: a Deform's send to its DeformEvent at every other client;
//  - bytes each client receives per stamp of the session;
//  - the server's tick p50/p99 (its Stats);
//  - the error column: TileHashes mismatches, and whether every client ends on the same
//    sequence with identical tiles.
// Clients and server share this machine's cores, so latencies include their contention.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "bench/harness.h"
#include "bench/server_stats.h"
#include "client/net/terrain_client.h"
#include "protocol/stamps/stamp_mix.h"  // the integration tests' child-process server
#include "protocol/stamps/stamp_validate.h"
#include "tests/integration/server_process.h"

namespace loam::bench {
namespace {

using clock_type = std::chrono::steady_clock;
using namespace std::chrono_literals;

// Gaussians and craters of 3..23 m on the coarse layer, clear of the world's edge. Each one
// changes the terrain (no min / max blend that may leave it as it was), so every accepted
// stamp reaches every client as an event, which the convergence check counts on.
QuantizedStamp session_stamp(StampRng& rng, const WorldParams& w) {
  RandomStampOptions o = random_stamp_options(w);
  o.kinds = {StampKind::kGaussian, StampKind::kCrater};
  o.blends = {BlendMode::kAdd, BlendMode::kSubtract};
  o.layer_share = {{1, 0}};
  const double inset = 40.0 * w.meters_per_sample;
  o.x0 += inset, o.y0 += inset, o.x1 -= inset, o.y1 -= inset;
  o.min_radius = 3.0;
  o.max_radius = 23.0;
  o.max_intensity[Layer::kCoarse] = 2.0;
  for (;;) {
    if (auto q = random_valid_stamp(rng, o, w)) return *q;
  }
}

struct Sent {
  uint32_t client_seq;
  clock_type::time_point at;
};

// One client's record of a run.
struct ClientRun {
  std::unique_ptr<client::TerrainClient> c;
  std::vector<Sent> sent;
  std::vector<double> ack_ms;
  std::map<uint64_t, clock_type::time_point> sent_at_global;        // accepted stamps: global seq -> send
  std::vector<std::pair<uint64_t, clock_type::time_point>> events;  // last_event_seq reached, when
  uint64_t bytes_before = 0, bytes_after = 0;
  uint64_t event_bytes_before = 0, event_bytes_after = 0;    // DeformEvent frames
  uint64_t region_bytes_before = 0, region_bytes_after = 0;  // RegionUpdate frames
  bool failed = false;
};

void mark_bytes(ClientRun& r, bool after) {
  const client::Connection& c = r.c->connection();
  (after ? r.bytes_after : r.bytes_before) = c.bytes_in();
  (after ? r.event_bytes_after : r.event_bytes_before) = c.bytes_in_of(wire::MessageType::kDeformEvent);
  (after ? r.region_bytes_after : r.region_bytes_before) = c.bytes_in_of(wire::MessageType::kRegionUpdate);
}

void record_events(ClientRun& r) {
  const uint64_t seen = r.c->last_event_seq();
  if (r.events.empty() || r.events.back().first < seen) r.events.push_back({seen, clock_type::now()});
}

// Sends at `rate` stamps per second until `end`, pumping in between; then waits for its acks.
void run_sender(ClientRun& r, uint32_t seed, double rate, clock_type::time_point start,
                clock_type::time_point end) {
  std::mt19937 rng(seed);
  StampRng stamps(seed);
  // Poisson arrivals: a fixed period would lock to the tick's phase and measure one point of it.
  std::exponential_distribution<double> gap(rate);
  auto next_gap = [&] {
    return std::chrono::duration_cast<clock_type::duration>(std::chrono::duration<double>(gap(rng)));
  };
  auto next = start + next_gap();
  std::deque<Sent> outstanding;
  auto collect_acks = [&] {
    while (!outstanding.empty()) {
      const auto a = r.c->ack(outstanding.front().client_seq);
      if (!a) break;
      r.ack_ms.push_back(
          std::chrono::duration<double, std::milli>(clock_type::now() - outstanding.front().at).count());
      if (a->accepted) r.sent_at_global[a->global_seq] = outstanding.front().at;
      outstanding.pop_front();
    }
  };
  while (clock_type::now() < end) {
    if (clock_type::now() >= next) {
      auto s = r.c->deform(session_stamp(stamps, r.c->welcome().world));
      if (!s) {
        r.failed = true;
        return;
      }
      outstanding.push_back({*s, clock_type::now()});
      next += next_gap();
    }
    const auto wait = std::max(
        0ms, std::min(2ms, std::chrono::duration_cast<std::chrono::milliseconds>(next - clock_type::now())));
    if (!r.c->pump(wait).ok()) {
      r.failed = true;
      return;
    }
    record_events(r);
    collect_acks();
  }
  const auto deadline = clock_type::now() + 20s;
  while (!outstanding.empty() && clock_type::now() < deadline) {
    if (!r.c->pump(2ms).ok()) break;
    record_events(r);
    collect_acks();
  }
  r.failed |= !outstanding.empty();
}

std::string ms_text(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.2f", v);
  return b;
}

double pct(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[size_t(p * double(v.size() - 1) + 0.5)];
}

// CPU seconds (user + system) a process has used, from /proc/PID/stat.
double cpu_seconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string stat((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const size_t close = stat.rfind(')');  // the command name may hold spaces
  if (close == std::string::npos) return 0;
  std::istringstream fields(stat.substr(close + 2));
  std::string f;
  unsigned long long utime = 0, stime = 0;
  for (int i = 3; i <= 15 && fields >> f; ++i) {
    if (i == 14) utime = std::stoull(f);
    if (i == 15) stime = std::stoull(f);
  }
  return double(utime + stime) / double(sysconf(_SC_CLK_TCK));
}

// Every coarse tile at every mip: a client in sync pays for a stamp at each level it holds.
std::vector<TileCoord> every_coarse_tile(const client::TerrainClient& c) {
  std::vector<TileCoord> out;
  for (int32_t m = 0; m < c.welcome().world.mip_count(); ++m) {
    const std::vector<TileCoord> level = c.all_coarse_tiles(m);
    out.insert(out.end(), level.begin(), level.end());
  }
  return out;
}

int run_session(const Context& ctx, Report& report) {
  const std::vector<int> counts = ctx.quick ? std::vector<int>{1, 4} : std::vector<int>{1, 4, 16, 32, 64};
  const double rate = 2.0;  // stamps per second per client, as the bots
  const double seconds = ctx.quick ? 1.5 : 8.0;
  const int tick_hz = 30;
  Table table("session",
              {"clients", "stamps/s offered", "stamps accepted", "ack p50 ms", "ack p99 ms", "fan-out p50 ms",
               "fan-out p99 ms", "bytes in / client / stamp", "event B / client / stamp",
               "region B / client / stamp", "server CPU ms / stamp", "server tick p50 ms (idle ticks too)",
               "server tick p99 ms", "hash mismatches", "converged"});
  Series ack50{"ack p50", {}}, ack99{"ack p99", {}}, fan50{"fan-out p50", {}}, fan99{"fan-out p99", {}};
  int failures = 0;
  for (const int n : counts) {
    const std::string dir = (std::filesystem::temp_directory_path() /
                             ("loam_bench_session_" + std::to_string(n) + "_" + std::to_string(::getpid())))
                                .string();
    std::filesystem::remove_all(dir);
    test::ServerProcess server;
    if (!server.start(dir, {"--tick-hz", std::to_string(tick_hz), "--deforms-per-second", "1000",
                            "--deform-burst", "1000", "--max-clients", "256", "--hashes-every", "15"})) {
      std::fprintf(stderr, "session: the server did not start: %s\n", server.log().c_str());
      return 1;
    }
    std::vector<ClientRun> runs(static_cast<size_t>(n));
    size_t tiles = 0;
    for (int i = 0; i < n; ++i) {
      runs[size_t(i)].c = std::make_unique<client::TerrainClient>();
      client::TerrainClient& c = *runs[size_t(i)].c;
      if (!c.connect("127.0.0.1", server.port(), "bench-" + std::to_string(i), wire::Role::kBot).ok() ||
          !c.subscribe(every_coarse_tile(c)).ok()) {
        std::fprintf(stderr, "session: client %d could not join\n", i);
        return 1;
      }
      tiles = every_coarse_tile(c).size();
    }
    for (ClientRun& r : runs) {
      if (!r.c->wait_until([&] { return r.c->store().held().size() >= tiles; }, 60s)) {
        std::fprintf(stderr, "session: a client never received its tiles\n");
        return 1;
      }
      mark_bytes(r, false);
    }
    const double cpu_before = cpu_seconds(server.pid());
    const auto start = clock_type::now() + 50ms;
    const auto end =
        start + std::chrono::duration_cast<clock_type::duration>(std::chrono::duration<double>(seconds));
    std::vector<std::thread> threads;
    for (int i = 0; i < n; ++i)
      threads.emplace_back(run_sender, std::ref(runs[size_t(i)]), uint32_t(i + 1), rate, start, end);
    for (auto& t : threads) t.join();
    threads.clear();
    uint64_t final_seq = 0;
    size_t accepted = 0;
    for (const ClientRun& r : runs) {
      accepted += r.sent_at_global.size();
      if (!r.sent_at_global.empty()) final_seq = std::max(final_seq, r.sent_at_global.rbegin()->first);
    }
    // Every client waits for the last event and one more TileHashes check after it.
    std::atomic<int> converged{0};
    for (ClientRun& r : runs) {
      threads.emplace_back([&r, &converged, final_seq] {
        const bool got = r.c->wait_until(
            [&] {
              record_events(r);
              return r.c->last_event_seq() >= final_seq;
            },
            30s);
        const size_t hashes = r.c->tile_hash_messages();
        r.c->wait_until([&] { return r.c->tile_hash_messages() > hashes; }, 10s);
        mark_bytes(r, true);
        converged += got;
      });
    }
    for (auto& t : threads) t.join();
    // Identical tiles everywhere.
    bool identical = true;
    for (const TileCoord& tc : runs[0].c->store().held())
      for (const ClientRun& r : runs) identical &= r.c->store().hash(tc) == runs[0].c->store().hash(tc);
    // Latencies.
    std::vector<double> acks, fanout;
    for (const ClientRun& r : runs) acks.insert(acks.end(), r.ack_ms.begin(), r.ack_ms.end());
    for (size_t j = 0; j < runs.size(); ++j) {
      const auto& ev = runs[j].events;
      for (size_t i = 0; i < runs.size(); ++i) {
        if (i == j) continue;
        for (const auto& [g, sent_at] : runs[i].sent_at_global) {
          const auto it = std::lower_bound(ev.begin(), ev.end(), g,
                                           [](const auto& e, uint64_t seq) { return e.first < seq; });
          if (it != ev.end())
            fanout.push_back(std::chrono::duration<double, std::milli>(it->second - sent_at).count());
        }
      }
    }
    uint64_t mismatches = 0, bytes = 0, event_bytes = 0, region_bytes = 0;
    bool failed = false;
    for (const ClientRun& r : runs) {
      mismatches += r.c->hash_mismatches();
      bytes += r.bytes_after - r.bytes_before;
      event_bytes += r.event_bytes_after - r.event_bytes_before;
      region_bytes += r.region_bytes_after - r.region_bytes_before;
      failed |= r.failed;
    }
    const double server_cpu_ms = (cpu_seconds(server.pid()) - cpu_before) * 1e3;
    const auto stats = server_stats(server.port());
    for (ClientRun& r : runs) (void)r.c->connection().send(wire::Bye{wire::ByeReason::kNormal, "bench done"});
    runs.clear();
    const int rc = server.terminate();
    std::filesystem::remove_all(dir);
    const bool ok = !failed && converged == n && identical && mismatches == 0 && rc == 0;
    failures += !ok;
    const auto per_client_stamp = [&](uint64_t b) {
      return accepted ? double(b) / double(n) / double(accepted) : 0.0;
    };
    const double per_stamp = per_client_stamp(bytes);
    table.add_row({std::to_string(n), ms_text(rate * n), std::to_string(accepted), ms_text(pct(acks, 0.5)),
                   ms_text(pct(acks, 0.99)), n > 1 ? ms_text(pct(fanout, 0.5)) : "-",
                   n > 1 ? ms_text(pct(fanout, 0.99)) : "-", std::to_string(int64_t(per_stamp + 0.5)),
                   std::to_string(int64_t(per_client_stamp(event_bytes) + 0.5)),
                   std::to_string(int64_t(per_client_stamp(region_bytes) + 0.5)),
                   accepted ? ms_text(server_cpu_ms / double(accepted)) : "-",
                   stats ? ms_text(stats->tick_p50_us / 1e3) : "n/a",
                   stats ? ms_text(stats->tick_p99_us / 1e3) : "n/a", std::to_string(mismatches),
                   ok ? "yes" : "NO"});
    ack50.points.push_back({double(n), pct(acks, 0.5)});
    ack99.points.push_back({double(n), pct(acks, 0.99)});
    if (n > 1) {
      fan50.points.push_back({double(n), pct(fanout, 0.5)});
      fan99.points.push_back({double(n), pct(fanout, 0.99)});
    }
    std::printf(
        "  %d clients: %zu stamps, ack p50 %.2f p99 %.2f ms, fan-out p50 %.2f p99 %.2f ms, %.0f "
        "B/client/stamp, "
        "%llu mismatches, %s\n",
        n, accepted, pct(acks, 0.5), pct(acks, 0.99), pct(fanout, 0.5), pct(fanout, 0.99), per_stamp,
        (unsigned long long)mismatches, ok ? "converged" : "NOT CONVERGED");
  }
  report.paragraph(
      "A loam-server process on loopback (" + std::to_string(tick_hz) +
      " Hz ticks, one fsync per tick, CPU stamp backend, the embedded terrain) and C clients in this "
      "process, each subscribed to every coarse tile at every mip and sending gaussians and craters at " +
      ms_text(rate) + " stamps/s on average (Poisson arrivals) for " + ms_text(seconds) +
      " s. `ack` is a Deform's send to its Ack at the sender: half a tick on average waiting for the "
      "tick, then the log's fsync and the apply. `fan-out` is the send to the DeformEvent's arrival at "
      "each other client. `bytes in` counts everything a client received during the run (events, "
      "acks, TileHashes every 15 ticks) per stamp of the session; `event B` and `region B` are the "
      "DeformEvent and RegionUpdate frames among them (headers included). `converged`: every client reached "
      "the last sequence, holds tiles identical to every other client's, and found no mismatch in "
      "the server's TileHashes. `server CPU` is the server process's user + system time during the "
      "run per accepted stamp (from /proc), idle ticks and TileHashes included; the clients' share of "
      "the cores does not inflate it as it does the latencies and tick times.");
  report.table(std::move(table));
  report.plot({"session_latency.png",
               "Latency against clients",
               "clients",
               "milliseconds",
               true,
               false,
               {ack50, ack99, fan50, fan99},
               {{"one tick", 1000.0 / tick_hz}}});
  return failures;
}

}  // namespace

LOAM_BENCH_SUITE(session,
                 "Server + C clients on loopback: ack and fan-out latency, bytes per stamp, convergence",
                 run_session);

}  // namespace loam::bench
