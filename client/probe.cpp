#include "client/probe.h"

#include <cstdio>
#include <variant>

#include "client/net/connection.h"

namespace loam::client {
namespace {

int fail(const ProbeOptions& o, const std::string& why) {
  std::fprintf(stderr, "loam-client probe %s:%u: %s\n", o.host.c_str(), unsigned(o.port), why.c_str());
  return 1;
}

}  // namespace

int run_probe(const ProbeOptions& o) {
  using clock = std::chrono::steady_clock;
  const auto deadline = clock::now() + o.timeout;
  Connection c;
  wire::Hello hello;
  hello.client_name = "probe";
  hello.requested_role = wire::Role::kSpectator;
  hello.access_token = o.token;
  c.set_tls(o.tls);
  auto welcome = c.connect(o.host, o.port, hello, o.timeout);
  if (!welcome) return fail(o, welcome.error().describe());
  constexpr uint32_t kRequestId = 1;
  if (const Status st = c.send(wire::StatsRequest{kRequestId}); !st.ok())
    return fail(o, st.error().describe());
  std::optional<wire::Stats> stats;
  while (!stats) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - clock::now());
    if (left.count() <= 0) return fail(o, "no Stats within the timeout (the tick loop may be stuck)");
    auto m = c.next(left);
    if (!m) return fail(o, m.error().describe());
    if (!*m) continue;
    if (auto* s = std::get_if<wire::Stats>(&**m); s && s->request_id == kRequestId) stats = *s;
    if (auto* e = std::get_if<wire::ErrorMsg>(&**m))
      return fail(o, std::string("server error ") + wire::to_string(e->code) + ": " + e->text);
  }
  (void)c.send(wire::Bye{wire::ByeReason::kNormal, "probe done"});
  c.close();
  const wire::Welcome& w = *welcome;
  const WorldParams& p = w.world;
  if (o.json) {
    std::printf(
        "{\"ok\":true,\"protocol\":\"%u.%u\",\"role\":\"%s\",\"world\":\"%dx%d tiles\",\"sequence\":%llu,"
        "\"clients\":%u,\"tick_hz\":%u,\"tick_p50_us\":%u,\"tick_p99_us\":%u,\"tick_overruns\":%llu,"
        "\"deforms_accepted\":%llu,\"deforms_rejected\":%llu,\"uptime_ms\":%llu}\n",
        unsigned(w.version_major), unsigned(w.version_minor), wire::to_string(w.granted_role), p.tiles_x,
        p.tiles_y, (unsigned long long)stats->global_sequence, stats->clients, unsigned(w.tick_rate_hz),
        stats->tick_p50_us, stats->tick_p99_us, (unsigned long long)stats->tick_overruns,
        (unsigned long long)stats->deforms_accepted, (unsigned long long)stats->deforms_rejected,
        (unsigned long long)stats->uptime_ms);
  } else {
    std::printf(
        "ok %s:%u protocol %u.%u, role %s, world %dx%d tiles, sequence %llu, %u clients, tick p50 %.2f ms "
        "p99 %.2f ms, %llu overruns, up %.0f s\n",
        o.host.c_str(), unsigned(o.port), unsigned(w.version_major), unsigned(w.version_minor),
        wire::to_string(w.granted_role), p.tiles_x, p.tiles_y, (unsigned long long)stats->global_sequence,
        stats->clients, stats->tick_p50_us / 1e3, stats->tick_p99_us / 1e3,
        (unsigned long long)stats->tick_overruns, double(stats->uptime_ms) / 1e3);
  }
  return 0;
}

}  // namespace loam::client
