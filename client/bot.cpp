#include "client/bot.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <random>

#include "client/net/terrain_client.h"
#include "client/render/clipmap_interest.h"
#include "client/view/roam_path.h"
#include "protocol/stamps/stamp_validate.h"

namespace loam::client {

namespace {

using namespace std::chrono_literals;

// A random stamp anywhere in the world, or, with `near`, within 150 m of that point.
QuantizedStamp bot_stamp(std::mt19937& rng, const WorldParams& w,
                         std::optional<std::pair<double, double>> near = std::nullopt) {
  const RectI r = w.sample_rect();
  double x0 = double(r.x0) * w.meters_per_sample, x1 = double(r.x1 - 1) * w.meters_per_sample;
  double y0 = double(r.y0) * w.meters_per_sample, y1 = double(r.y1 - 1) * w.meters_per_sample;
  if (near) {
    x0 = std::max(x0, near->first - 150.0), x1 = std::min(x1, near->first + 150.0);
    y0 = std::max(y0, near->second - 150.0), y1 = std::min(y1, near->second + 150.0);
  }
  std::uniform_real_distribution<double> ux(x0, x1);
  std::uniform_real_distribution<double> uy(y0, y1);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (;;) {
    StampParams p;
    const uint32_t pick = uint32_t(rng() % 10);
    p.center_x = ux(rng);
    p.center_y = uy(rng);
    p.radius = 2.0 + 30.0 * unit(rng);
    p.rotation = 6.28 * unit(rng);
    p.intensity = -2.0 + 4.0 * unit(rng);
    p.kind = StampKind::kGaussian;
    if (pick < 4) p.kind = StampKind::kCrater, p.intensity = 0.5 + 2.0 * unit(rng), p.shape = 0.3;
    if (pick == 4) p.kind = StampKind::kFootprint, p.intensity = 0.2, p.radius = 1.5;
    if (pick == 5)
      p.kind = StampKind::kShockwave, p.radius = 6.0, p.intensity = 0.4, p.steps = 40, p.speed = 0.6,
      p.damping = 0.02;
    if (pick == 6)
      p.kind = StampKind::kGaussian, p.layer = Layer::kDetail, p.radius = 1.0, p.intensity = 0.05;
    auto q = validate_stamp(p, w);
    if (q) return *q;
  }
}

}  // namespace

int run_bot(const BotOptions& o) {
  const std::string& host = o.host;
  const uint16_t port = o.port;
  const std::string& name = o.name;
  const uint32_t stamps = o.stamps, seed = o.seed;
  const double rate = o.rate;
  client::TerrainClient c;
  if (const Status st = c.connect(host, port, name, wire::Role::kBot, o.token); !st.ok()) {
    std::fprintf(stderr, "loam-client bot: %s\n", st.error().describe().c_str());
    return kBotCannotJoin;
  }
  std::printf("bot %s: joined as client %u at sequence %llu\n", name.c_str(), c.welcome().client_id,
              (unsigned long long)c.welcome().global_sequence);
  const WorldParams& world = c.welcome().world;
  const auto started = std::chrono::steady_clock::now();
  std::optional<render::ClipmapInterest> interest;
  std::optional<wire::Focus> focus_sent;
  // A roaming bot follows its position as a viewer follows its camera.
  const auto follow = [&]() -> Status {
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    const auto [x, y] = roam_position(world, seed, o.roam_mps, t);
    const render::ClipmapInterest::Delta d = interest->update(x, y);
    if (!d.unsubscribe.empty()) LOAM_TRY(c.unsubscribe(d.unsubscribe));
    const double step = 0.25 * kTileSize * world.meters_per_sample;
    const bool moved = !focus_sent || std::hypot(x - focus_sent->x_m, y - focus_sent->y_m) > step;
    if (d.subscribe.empty() && !moved) return {};
    focus_sent = wire::Focus{x, y};
    return c.subscribe(d.subscribe, focus_sent);
  };
  if (o.roam_mps > 0) {
    interest.emplace(world, render::InterestConfig{});
    if (!follow().ok()) return kBotCannotJoin;
  } else if (!c.subscribe(c.all_coarse_tiles(0)).ok()) {
    return kBotCannotJoin;
  }
  std::mt19937 rng(seed);
  std::vector<uint32_t> sent;
  const auto period = std::chrono::duration<double>(1.0 / rate);
  auto next = std::chrono::steady_clock::now();
  for (uint32_t i = 0; i < stamps; ++i) {
    std::optional<std::pair<double, double>> near;
    if (interest) {
      const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      near = roam_position(world, seed, o.roam_mps, t);
    }
    auto s = c.deform(bot_stamp(rng, world, near));
    if (!s) break;
    sent.push_back(*s);
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    while (std::chrono::steady_clock::now() < next) {
      if (interest && !follow().ok()) break;
      if (!c.pump(std::min<std::chrono::milliseconds>(100ms,
                                                      std::chrono::duration_cast<std::chrono::milliseconds>(
                                                          next - std::chrono::steady_clock::now()) +
                                                          1ms))
               .ok())
        break;
    }
  }
  c.wait_until([&] { return sent.empty() || c.ack(sent.back()).has_value(); }, 10s);
  size_t accepted = 0, refused = 0;
  for (uint32_t s : sent) {
    const auto ack = c.ack(s);
    if (ack) (ack->accepted ? accepted : refused) += 1;
  }
  const size_t unacknowledged = sent.size() - accepted - refused, unsent = size_t(stamps) - sent.size();
  // Let the next TileHashes arrive so the report includes a comparison.
  const size_t hashes = c.tile_hash_messages();
  c.wait_until([&] { return c.tile_hash_messages() > hashes; }, 5s);
  const auto& k = c.store().counters();
  std::printf(
      "bot %s: %zu/%zu stamps accepted; events applied %llu, regions %llu, hash checks %llu, mismatches "
      "%llu\n",
      name.c_str(), accepted, sent.size(), (unsigned long long)k.events_applied,
      (unsigned long long)k.regions, (unsigned long long)k.hash_checks,
      (unsigned long long)k.hash_mismatches);
  if (refused + unacknowledged + unsent > 0) {
    std::fprintf(stderr, "bot %s: %zu stamps refused, %zu unacknowledged, %zu never sent\n", name.c_str(),
                 refused, unacknowledged, unsent);
  }
  (void)c.connection().send(wire::Bye{wire::ByeReason::kNormal, "bot done"});
  if (k.hash_mismatches != 0) return kBotMismatch;
  return refused + unacknowledged + unsent == 0 ? kBotOk : kBotLostStamps;
}

}  // namespace loam::client
