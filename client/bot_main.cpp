// loam-client: the client program. `bot` is the headless bot (no GL): it joins a session,
// subscribes to the world, deforms it with seeded random stamps at a steady rate, checks its
// confirmed store against the server's TileHashes, and reports. `render` draws the clipmap
// headless through EGL into PNGs (client/render/headless.h). The viewer joins later.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <random>
#include <thread>

#include "client/net/terrain_client.h"
#ifdef LOAM_HAVE_RENDER
#include "client/render/headless.h"
#endif
#include "protocol/stamps/stamp_validate.h"

namespace {

using namespace loam;
using namespace std::chrono_literals;

QuantizedStamp bot_stamp(std::mt19937& rng, const WorldParams& w) {
  const RectI r = w.sample_rect();
  std::uniform_real_distribution<double> ux(double(r.x0) * w.meters_per_sample,
                                            double(r.x1 - 1) * w.meters_per_sample);
  std::uniform_real_distribution<double> uy(double(r.y0) * w.meters_per_sample,
                                            double(r.y1 - 1) * w.meters_per_sample);
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

int run_bot(const std::string& host, uint16_t port, const std::string& name, uint32_t stamps, double rate,
            uint32_t seed) {
  client::TerrainClient c;
  if (const Status st = c.connect(host, port, name, wire::Role::kBot); !st.ok()) {
    std::fprintf(stderr, "loam-client bot: %s\n", st.error().describe().c_str());
    return 1;
  }
  std::printf("bot %s: joined as client %u at sequence %llu\n", name.c_str(), c.welcome().client_id,
              (unsigned long long)c.welcome().global_sequence);
  if (!c.subscribe(c.all_coarse_tiles(0)).ok()) return 1;
  std::mt19937 rng(seed);
  std::vector<uint32_t> sent;
  const auto period = std::chrono::duration<double>(1.0 / rate);
  auto next = std::chrono::steady_clock::now();
  for (uint32_t i = 0; i < stamps; ++i) {
    auto s = c.deform(bot_stamp(rng, c.welcome().world));
    if (!s) break;
    sent.push_back(*s);
    next += std::chrono::duration_cast<std::chrono::steady_clock::duration>(period);
    while (std::chrono::steady_clock::now() < next) {
      if (!c.pump(std::chrono::duration_cast<std::chrono::milliseconds>(next -
                                                                        std::chrono::steady_clock::now()) +
                  1ms)
               .ok())
        break;
    }
  }
  c.wait_until([&] { return sent.empty() || c.ack(sent.back()).has_value(); }, 10s);
  size_t accepted = 0;
  for (uint32_t s : sent) accepted += c.ack(s) && c.ack(s)->accepted;
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
  (void)c.connection().send(wire::Bye{wire::ByeReason::kNormal, "bot done"});
  return k.hash_mismatches == 0 ? 0 : 3;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"loam-client: Loam's client (bot, headless renderer)"};
  app.require_subcommand(1);
  std::string host = "127.0.0.1", name = "bot";
  uint16_t port = 7878;
  uint32_t stamps = 100, seed = 1;
  double rate = 10.0;
  auto* bot = app.add_subcommand("bot", "Join a session and deform it with random stamps");
  bot->add_option("--host", host)->capture_default_str();
  bot->add_option("--port", port)->capture_default_str();
  bot->add_option("--name", name)->capture_default_str();
  bot->add_option("--stamps", stamps, "How many stamps to send")->capture_default_str();
  bot->add_option("--rate", rate, "Stamps per second")->capture_default_str()->check(CLI::Range(0.1, 1000.0));
  bot->add_option("--seed", seed)->capture_default_str();
#ifdef LOAM_HAVE_RENDER
  render::RenderCommandOptions ro;
  std::string size = "1280x720";
  auto* render_cmd = app.add_subcommand("render", "Render one frame or a camera path headless (EGL) to PNG");
  auto* src_dem = render_cmd->add_option("--dem", ro.dem, "DEM file (default: the embedded default terrain)");
  auto* src_snap = render_cmd->add_option("--snapshot", ro.snapshot,
                                          "Snapshot folder, or a data folder (its newest snapshot)");
  auto* src_server =
      render_cmd->add_option("--server", ro.server, "HOST:PORT of a loam-server: render its live session");
  src_dem->excludes(src_snap)->excludes(src_server);
  src_snap->excludes(src_server);
  render_cmd->add_option("--camera", ro.camera, "Camera position x,y,z (world meters)")->delimiter(',');
  render_cmd->add_option("--look", ro.look, "Point looked at x,y,z (world meters)")->delimiter(',');
  render_cmd->add_option("--size", size, "WIDTHxHEIGHT")->capture_default_str();
  render_cmd->add_option("--out", ro.out, "PNG file (a path numbers them: out_0000.png, ...)")
      ->capture_default_str();
  render_cmd->add_option("--path", ro.path, "Camera path file: one 'x y z tx ty tz' line per frame");
  render_cmd->add_flag("!--no-morph", ro.morph, "Disable geomorphing (shows level pops)");
  render_cmd->add_option("--n", ro.n, "Vertices per clipmap level side (2^k - 1)")->capture_default_str();
  render_cmd->add_option("--levels", ro.levels, "Clipmap levels (0: from --view-distance)")
      ->capture_default_str();
  render_cmd->add_option("--view-distance", ro.view_distance, "Meters")->capture_default_str();
  render_cmd->add_option("--fov", ro.fov_y_degrees, "Vertical field of view, degrees")->capture_default_str();
#endif
  CLI11_PARSE(app, argc, argv);
  if (*bot) return run_bot(host, port, name, stamps, rate, seed);
#ifdef LOAM_HAVE_RENDER
  if (*render_cmd) {
    int w = 0, h = 0;
    if (std::sscanf(size.c_str(), "%dx%d", &w, &h) != 2) {
      std::fprintf(stderr, "loam-client render: --size wants WIDTHxHEIGHT, got %s\n", size.c_str());
      return 2;
    }
    ro.width = w, ro.height = h;
    return render::run_render_command(ro);
  }
#endif
  return 0;
}
