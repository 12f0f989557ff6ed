#include "client/bot.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <thread>

#include "client/controls/roam_path.h"
#include "client/lod/clipmap_interest.h"
#include "client/net/terrain_client.h"
#include "dem/refined_default.h"
#include "protocol/stamps/stamp_mix.h"
#include "protocol/stamps/stamp_validate.h"

namespace loam::client {

namespace {

using namespace std::chrono_literals;

// The bot's mix, drawn by the shared seeded generator (the same seed gives the same stamps
// with any compiler and standard library): craters 4 in 10, gaussians (add or subtract) 4 in
// 10 with one of them on the detail layer, footprints and shockwaves 1 in 10 each; radii
// 2-32 m (footprints 1.5 m, shockwaves 6 m); anywhere in the world, or within 150 m of `near`.
QuantizedStamp bot_stamp(StampRng& rng, const WorldParams& w,
                         std::optional<std::pair<double, double>> near = std::nullopt) {
  RandomStampOptions o = random_stamp_options(w);
  o.kinds = {StampKind::kCrater,    StampKind::kCrater,   StampKind::kCrater,   StampKind::kCrater,
             StampKind::kGaussian,  StampKind::kGaussian, StampKind::kGaussian, StampKind::kGaussian,
             StampKind::kFootprint, StampKind::kShockwave};
  o.blends = {BlendMode::kAdd, BlendMode::kSubtract};
  o.layer_share = {{3, 1}};  // of the gaussians: the other kinds stay on the coarse layer
  o.layer_kinds[Layer::kDetail] = {StampKind::kGaussian};
  o.min_radius = 2.0;
  o.max_radius = 32.0;
  o.max_radius_of_kind[size_t(StampKind::kFootprint)] = 1.5;
  o.max_radius_of_kind[size_t(StampKind::kShockwave)] = 6.0;
  o.max_intensity[Layer::kCoarse] = 2.5;
  o.min_intensity[Layer::kCoarse] = 0.2;
  o.max_intensity[Layer::kDetail] = 0.25;
  if (near) {
    o.x0 = std::max(o.x0, near->first - 150.0), o.x1 = std::min(o.x1, near->first + 150.0);
    o.y0 = std::max(o.y0, near->second - 150.0), o.y1 = std::min(o.y1, near->second + 150.0);
  }
  for (;;) {
    if (auto q = random_valid_stamp(rng, o, w)) return *q;
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
  // Untouched tiles of a base this program can generate (the refined default) are made here.
  c.set_base_provider(generate_known_base);
  c.set_tls(o.tls);
  if (const Status st = c.connect(host, port, name, wire::Role::kBot, o.token); !st.ok()) {
    std::fprintf(stderr, "loam-client bot: %s\n", st.error().describe().c_str());
    return kBotCannotJoin;
  }
  std::printf("bot %s: joined as client %u at sequence %llu\n", name.c_str(), c.welcome().client_id,
              (unsigned long long)c.welcome().global_sequence);
  const WorldParams& world = c.welcome().world;
  const auto started = std::chrono::steady_clock::now();
  std::optional<lod::ClipmapInterest> interest;
  std::optional<wire::Focus> focus_sent;
  // A roaming bot follows its position as a viewer follows its camera.
  const auto follow = [&]() -> Status {
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    const auto [x, y] = controls::roam_position(world, seed, o.roam_mps, t);
    const lod::ClipmapInterest::Delta d = interest->update(x, y);
    if (!d.unsubscribe.empty()) LOAM_TRY(c.unsubscribe(d.unsubscribe));
    const double step = 0.25 * kTileSize * world.meters_per_sample;
    const bool moved = !focus_sent || std::hypot(x - focus_sent->x_m, y - focus_sent->y_m) > step;
    if (d.subscribe.empty() && !moved) return {};
    focus_sent = wire::Focus{x, y};
    return c.subscribe(d.subscribe, focus_sent);
  };
  if (o.roam_mps > 0) {
    interest.emplace(world, lod::InterestConfig{});
    if (!follow().ok()) return kBotCannotJoin;
  } else if (!c.subscribe(c.all_coarse_tiles(0)).ok()) {
    return kBotCannotJoin;
  }
  // The connection is gone: reconnect as the viewer does (the store resumes from the versions
  // it holds, unanswered Deforms go again under the resume key), retrying for a few seconds.
  int reconnects = 0;
  const auto recover = [&]() -> bool {
    const auto give_up = std::chrono::steady_clock::now() + 5s;
    while (std::chrono::steady_clock::now() < give_up) {
      if (c.reconnect(host, port).ok()) {
        ++reconnects;
        std::printf("bot %s: reconnected\n", name.c_str());
        if (interest) focus_sent.reset();
        return !interest || follow().ok();
      }
      std::this_thread::sleep_for(200ms);  // back-off between attempts
    }
    return false;
  };
  StampRng rng(seed);
  std::vector<uint32_t> sent;
  const auto period = std::chrono::duration<double>(1.0 / rate);
  auto next = std::chrono::steady_clock::now();
  bool lost = false;
  for (uint32_t i = 0; i < stamps && !lost; ++i) {
    std::optional<std::pair<double, double>> near;
    if (interest) {
      const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
      near = controls::roam_position(world, seed, o.roam_mps, t);
    }
    auto s = c.deform(bot_stamp(rng, world, near));  // queued; it leaves when the link allows
    if (!s) break;
    sent.push_back(*s);
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    while (!lost && std::chrono::steady_clock::now() < next) {
      const auto wait = std::min<std::chrono::milliseconds>(
          100ms,
          std::chrono::duration_cast<std::chrono::milliseconds>(next - std::chrono::steady_clock::now()) +
              1ms);
      if ((interest && !follow().ok()) || !c.pump(wait).ok()) lost = !recover();
    }
  }
  // Every answer, reconnecting if the link goes while waiting for them.
  const auto all_answered = [&] {
    return sent.empty() || (c.deforms_queued() == 0 && c.deforms_unacked() == 0);
  };
  for (int attempt = 0; !lost && attempt < 4; ++attempt) {
    if (c.wait_until(all_answered, 10s)) break;
    if (c.connection().open() || !recover()) break;
  }
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
      name.c_str(), accepted, size_t(stamps), (unsigned long long)k.events_applied,
      (unsigned long long)k.regions, (unsigned long long)k.hash_checks,
      (unsigned long long)k.hash_mismatches);
  if (refused + unacknowledged + unsent > 0) {
    std::fprintf(stderr, "bot %s: %zu stamps refused, %zu unacknowledged, %zu never sent\n", name.c_str(),
                 refused, unacknowledged, unsent);
  }
  if (reconnects > 0) std::printf("bot %s: %d reconnects\n", name.c_str(), reconnects);
  (void)c.connection().send(wire::Bye{wire::ByeReason::kNormal, "bot done"});
  if (k.hash_mismatches != 0) return kBotMismatch;
  return refused + unacknowledged + unsent == 0 ? kBotOk : kBotLostStamps;
}

}  // namespace loam::client
