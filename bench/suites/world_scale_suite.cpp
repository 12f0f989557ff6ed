// Suite `world-scale`: worlds of tens of kilometres. It measures the refined default world
// (dem/refined_default.h): the time to generate a 256^2 tile at every mip on one core (target
// <= 1 ms, so a client flying at 300 m/s keeps up), and whether it looks like terrain: slope
// histograms (Horn's method, as `gdaldem slope`) of the refined world at 1, 8 and 64 m against
// real DEMs from ../shared/data at their own resolution, and against the old whole-world
// default (the same crop squeezed to 2 m), with hillshades beside the report. Then the import
// of a 32768^2 GeoTIFF into a tile pack in bounded memory, serving the refined world and the
// pack to roaming bots, headless viewers and a 300 m/s flight, a join at 128 KiB/s, and
// incremental snapshots with retention over a long session (world_scale_store.h).
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "bench/harness.h"
#include "bench/server_stats.h"
#include "bench/suites/world_scale_store.h"
#include "client/net/terrain_client.h"
#include "dem/default_terrain.h"
#include "dem/dem_raster.h"
#include "dem/image_file.h"
#include "dem/refined_default.h"
#include "server/server_config.h"
#include "tests/integration/server_process.h"
#include "tests/support/child_process.h"

namespace loam::bench {
namespace {

namespace fs = std::filesystem;

// A height field in metres with its spacing, for slope statistics and hillshades.
struct Field {
  std::string name;
  int64_t w = 0, h = 0;
  double dx = 1, dy = 1;
  std::vector<double> z;
  double at(int64_t x, int64_t y) const { return z[size_t(y * w + x)]; }
};

constexpr int kSlopeBins = 9;
constexpr double kSlopeEdges[kSlopeBins] = {2, 5, 10, 15, 20, 30, 40, 50, 90};

struct SlopeStats {
  int64_t n = 0;
  double hist[kSlopeBins] = {};
  double mean = 0, p50 = 0, p90 = 0, p99 = 0;
};

// Horn's 3x3 gradient (gdaldem slope -alg Horn) at an interior sample, in m/m.
std::pair<double, double> horn_gradient(const Field& f, int64_t x, int64_t y) {
  const double gx = ((f.at(x + 1, y - 1) + 2 * f.at(x + 1, y) + f.at(x + 1, y + 1)) -
                     (f.at(x - 1, y - 1) + 2 * f.at(x - 1, y) + f.at(x - 1, y + 1))) /
                    (8 * f.dx);
  const double gy = ((f.at(x - 1, y + 1) + 2 * f.at(x, y + 1) + f.at(x + 1, y + 1)) -
                     (f.at(x - 1, y - 1) + 2 * f.at(x, y - 1) + f.at(x + 1, y - 1))) /
                    (8 * f.dy);
  return {gx, gy};
}

// Slopes in degrees over interior samples.
void add_slopes(const Field& f, std::vector<double>& slopes) {
  for (int64_t y = 1; y + 1 < f.h; ++y) {
    for (int64_t x = 1; x + 1 < f.w; ++x) {
      const auto [gx, gy] = horn_gradient(f, x, y);
      slopes.push_back(std::atan(std::sqrt(gx * gx + gy * gy)) * 180.0 / M_PI);
    }
  }
}

SlopeStats stats_of(std::vector<double> slopes) {
  SlopeStats s;
  s.n = int64_t(slopes.size());
  if (slopes.empty()) return s;
  double sum = 0;
  for (double v : slopes) {
    sum += v;
    int b = 0;
    while (b + 1 < kSlopeBins && v >= kSlopeEdges[b]) ++b;
    s.hist[b] += 1;
  }
  for (double& h : s.hist) h /= double(slopes.size());
  s.mean = sum / double(slopes.size());
  std::sort(slopes.begin(), slopes.end());
  const auto q = [&](double p) {
    return slopes[std::min(slopes.size() - 1, size_t(p * double(slopes.size())))];
  };
  s.p50 = q(0.5);
  s.p90 = q(0.9);
  s.p99 = q(0.99);
  return s;
}

// A rect of the refined world at a mip, in metres.
Field refined_field(const RefinedWorld& w, int32_t mip, const RectI& r) {
  std::vector<uint16_t> q(size_t(r.area()));
  w.base.generate(mip, r, q);
  Field f{"",
          r.width(),
          r.height(),
          std::ldexp(w.params.meters_per_sample, mip),
          std::ldexp(w.params.meters_per_sample, mip),
          {}};
  f.z.resize(q.size());
  for (size_t i = 0; i < q.size(); ++i) f.z[i] = w.params.height_meters(q[i]);
  return f;
}

bool write_hillshade(const Field& f, const std::string& path) {
  std::vector<uint8_t> px(size_t(f.w * f.h), 0);
  const double az = 315.0 * M_PI / 180.0, alt = 45.0 * M_PI / 180.0;
  for (int64_t y = 1; y + 1 < f.h; ++y) {
    for (int64_t x = 1; x + 1 < f.w; ++x) {
      const auto [gx, gy] = horn_gradient(f, x, y);
      const double slope = std::atan(std::sqrt(gx * gx + gy * gy));
      const double aspect = std::atan2(gy, -gx);
      const double shade = std::sin(alt) * std::cos(slope) +
                           std::cos(alt) * std::sin(slope) * std::cos(az - M_PI / 2 - aspect);
      px[size_t(y * f.w + x)] = uint8_t(std::clamp(shade, 0.0, 1.0) * 255.0);
    }
  }
  return write_image_file(path, image_view(int32_t(f.w), int32_t(f.h), 1, std::span<const uint8_t>(px))).ok();
}

// Peak resident set (VmHWM) of a live process, MiB; 0 when unreadable.
double peak_rss_mib(pid_t pid) {
  std::FILE* f = std::fopen(("/proc/" + std::to_string(pid) + "/status").c_str(), "r");
  if (!f) return 0;
  char line[256];
  double kib = 0;
  while (std::fgets(line, sizeof line, f))
    if (std::sscanf(line, "VmHWM: %lf kB", &kib) == 1) break;
  std::fclose(f);
  return kib / 1024.0;
}

struct ServeResult {
  bool ran = false;
  size_t view_tiles = 0;  // the whole-world coarse view: every tile of mips 6 and up
  double join_generated_s = -1, join_downloaded_s = -1;
  uint64_t join_generated_chunks = 0, join_downloaded_chunks = 0;
  int bots = 0, bots_ok = 0;
  int viewers = 0, viewers_ok = 0;  // headless viewers; ok = exit 0 (no mismatch, no divergence)
  double viewer_rss_max_mib = 0, viewer_gpu_max_mib = 0, viewer_cpu_max_mib = 0;
  // A viewer flying a loop at 300 m/s: frames with a level on a coarser mip, and waits.
  bool flight_ran = false, flight_ok = false;
  double flight_seconds = 0, flight_lacking_pct = 0, flight_waiting_pct = 0, flight_longest_s = 0;
  long long flight_frames = 0;
  double seconds = 0;
  double server_rss_mib = 0, bot_rss_max_mib = 0;
  uint64_t accepted = 0, bytes_out = 0;
  double tick_p99_ms = 0, tick_p50_ms = 0;
  double overrun_pct = 0;  // ticks longer than their period (33 ms), of every tick
  std::string note;
};

// A loam-server on a world (`terrain`: its serve options) and `bots` roaming `loam-client
// bot` processes, each stamping near itself and checking its tiles' hashes; headless viewers
// (and, with `fly`, one flying at 300 m/s); peak RSS of every process. `join`: first time a
// client joining at 128 KiB/s to the whole coarse view (generating the base; with
// `download_join` also one downloading it).
ServeResult serve_world(const std::vector<std::string>& terrain, int bots, int viewers, double seconds,
                        double rate, uint64_t cache_mb, bool time_join, bool download_join, bool fly_viewer) {
  ServeResult r;
#ifndef LOAM_CLIENT_BINARY
  (void)terrain, (void)bots, (void)viewers, (void)seconds, (void)rate, (void)cache_mb, (void)time_join,
      (void)download_join, (void)fly_viewer;
  r.note = "loam-client was not built";
  return r;
#else
  const std::string dir =
      (fs::temp_directory_path() / ("loam_bench_world_scale_" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  test::ServerProcess server;
  std::vector<std::string> serve_args = terrain;
  serve_args.insert(serve_args.end(),
                    {"--cache-mb", std::to_string(cache_mb), "--client-budget", std::to_string(128 << 10)});
  if (!server.start(dir, serve_args)) {
    r.note = "the server did not start: " + server.log();
    return r;
  }
  // Joins at 128 KiB/s: the time until the whole-world coarse view is held, by a client that
  // generates the base and by one that downloads it.
  const auto join = [&](bool generate, double& held_after_s, uint64_t& chunks) {
    client::TerrainClient c;
    if (generate) c.set_base_provider(generate_known_base);
    const auto start = std::chrono::steady_clock::now();
    if (!c.connect("127.0.0.1", server.port(), generate ? "join-generates" : "join-downloads").ok()) return;
    std::vector<TileCoord> view;
    const WorldParams& w = c.welcome().world;
    for (int32_t m = 6; m < w.mip_count(); ++m) {
      const RectI t = w.tile_range(m);
      for (int64_t ty = t.y0; ty < t.y1; ++ty)
        for (int64_t tx = t.x0; tx < t.x1; ++tx)
          view.push_back({Layer::kCoarse, uint8_t(m), int32_t(tx), int32_t(ty)});
    }
    r.view_tiles = view.size();
    if (!c.subscribe(view).ok()) return;
    if (c.wait_until([&] { return c.store().held().size() == view.size(); }, std::chrono::seconds(120)))
      held_after_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    chunks = c.region_chunks_received();
  };
  if (time_join) join(true, r.join_generated_s, r.join_generated_chunks);
  if (time_join && download_join)
    join(false, r.join_downloaded_s, r.join_downloaded_chunks);  // ~35 s at 128 KiB/s

  const auto t0 = std::chrono::steady_clock::now();
  std::vector<pid_t> pids;
  const std::string stamps = std::to_string(int(seconds * rate));
  for (int i = 0; i < bots; ++i) {
    std::vector<std::string> args = {LOAM_CLIENT_BINARY, "bot",
                                     "--port",           std::to_string(server.port()),
                                     "--name",           "roamer" + std::to_string(i),
                                     "--roam",           "30",
                                     "--stamps",         stamps,
                                     "--rate",           std::to_string(rate),
                                     "--seed",           std::to_string(i + 1)};
    if (const pid_t pid = test::spawn_child(args, "/dev/null", ""); pid > 0) pids.push_back(pid);
  }
  r.bots = int(pids.size());
  // Headless viewers with the classic clipmap at n = 255 orbiting the centre and stamping where
  // they look; each prints its terrain memory (GPU: level textures + tile pages; CPU: held
  // tiles) every second.
  std::vector<std::pair<pid_t, std::string> > viewer_pids;
  // The last one flies (at most 60 s) instead of orbiting.
  const bool fly = fly_viewer && viewers > 0;
  for (int i = 0; i < viewers + (fly ? 1 : 0); ++i) {
    const std::string log = dir + "/viewer" + std::to_string(i) + ".log";
    std::vector<std::string> args = {LOAM_CLIENT_BINARY,
                                     "view",
                                     "--headless",
                                     "--port",
                                     std::to_string(server.port()),
                                     "--name",
                                     "viewer" + std::to_string(i),
                                     "--seconds",
                                     fmt("%.0f", seconds),
                                     "--lod",
                                     "classic",
                                     "--n",
                                     "255",
                                     "--size",
                                     "640x360",
                                     "--stamp-every",
                                     "2",
                                     "--screenshot",
                                     dir + "/viewer" + std::to_string(i) + ".png",
                                     "--screenshot-every",
                                     "0"};
    if (i == viewers) {
      r.flight_seconds = std::min(seconds, 60.0);
      args[8] = fmt("%.0f", r.flight_seconds);          // --seconds
      args.erase(args.begin() + 9, args.begin() + 13);  // --lod classic --n 255: the default viewer
      args.insert(args.end(), {"--fly", "300"});
    }
    if (const pid_t pid = test::spawn_child(args, log, ""); pid > 0) viewer_pids.push_back({pid, log});
  }
  r.viewers = int(viewer_pids.size()) - (fly ? 1 : 0);
  for (pid_t pid : pids) {
    const test::ChildExit e = test::wait_child(pid);
    r.bot_rss_max_mib = std::max(r.bot_rss_max_mib, e.peak_rss_mib);
    r.bots_ok += e.ok();
  }
  for (size_t v = 0; v < viewer_pids.size(); ++v) {
    const auto& [pid, log] = viewer_pids[v];
    const test::ChildExit e = test::wait_child(pid);
    if (!e.waited) continue;
    if (fly && v + 1 == viewer_pids.size()) {
      r.flight_ran = true;
      r.flight_ok = e.ok();
      std::ifstream in(log);
      for (std::string line; std::getline(in, line);) {
        std::sscanf(
            line.c_str(),
            "viewer coverage: %lld frames, %lf%% with a level on a coarser mip, %lf%% waiting over 0.5 s, "
            "longest wait %lf s",
            &r.flight_frames, &r.flight_lacking_pct, &r.flight_waiting_pct, &r.flight_longest_s);
      }
      continue;
    }
    r.viewer_rss_max_mib = std::max(r.viewer_rss_max_mib, e.peak_rss_mib);
    r.viewers_ok += e.ok();
    std::ifstream in(log);
    for (std::string line; std::getline(in, line);) {
      double gpu = 0, cpu = 0;
      const size_t at = line.find("terrain memory GPU ");
      if (at == std::string::npos) continue;
      int pages = 0;
      if (std::sscanf(line.c_str() + at, "terrain memory GPU %lf MiB (%d pages), CPU %lf MiB", &gpu, &pages,
                      &cpu) == 3) {
        r.viewer_gpu_max_mib = std::max(r.viewer_gpu_max_mib, gpu);
        r.viewer_cpu_max_mib = std::max(r.viewer_cpu_max_mib, cpu);
      }
    }
  }
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (auto st = server_stats(server.port())) {
    r.accepted = st->deforms_accepted;
    r.bytes_out = st->bytes_out;
    r.tick_p99_ms = st->tick_p99_us / 1000.0;
    r.tick_p50_ms = st->tick_p50_us / 1000.0;
    const double ticks = double(st->uptime_ms) / 1000.0 * double(server::ServerConfig{}.tick_hz);
    r.overrun_pct = ticks > 0 ? 100.0 * double(st->tick_overruns) / ticks : 0.0;
  }
  r.server_rss_mib = peak_rss_mib(server.pid());
  server.terminate();
  fs::remove_all(dir);
  r.ran = true;
  return r;
#endif
}

int run_world_scale(const Context& ctx, Report& report) {
  auto world = load_refined_default();
  if (!world) {
    std::fprintf(stderr, "world-scale: %s\n", world.error().describe().c_str());
    return 1;
  }
  const RefinedWorld& w = *world;
  const int32_t mips = w.params.mip_count();

  // --- Tile generation time per mip, over tiles spread across the world (one core). ---
  Table gen("refined_tiles", {"mip", "spacing m", "tiles timed", "ms / tile (median)", "p99 ms", "max ms",
                              "Msamples/s", "target <= 1 ms"});
  std::vector<uint16_t> tile(static_cast<size_t>(kTileSamples));
  Series gen_series{"median ms per 256^2 tile", {}};
  int failures = 0;
  uint64_t lcg = 99;
  for (int32_t mip = 0; mip < mips; ++mip) {
    const RectI range = w.params.tile_range(mip);
    const int n = ctx.quick ? 20 : 400;
    std::vector<double> times;
    for (int i = 0; i < n + 5; ++i) {
      lcg = lcg * 6364136223846793005ull + 1442695040888963407ull;
      const int32_t tx = int32_t(range.x0 + int64_t((lcg >> 33) % uint64_t(range.width())));
      const int32_t ty = int32_t(range.y0 + int64_t((lcg >> 13) % uint64_t(range.height())));
      const auto t0 = std::chrono::steady_clock::now();
      w.base.generate_tile(mip, tx, ty, tile);
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (i >= 5) times.push_back(s);  // the first calls size the scratch buffers
    }
    std::sort(times.begin(), times.end());
    const double med = times[times.size() / 2],
                 p99 = times[std::min(times.size() - 1, times.size() * 99 / 100)];
    const bool ok = med <= 1e-3;
    if (!ok && !ctx.quick && !ctx.sanitized) ++failures;
    gen.add_row({std::to_string(mip), fmt("%.0f", std::ldexp(1.0, mip)), std::to_string(times.size()),
                 fmt("%.3f", med * 1e3), fmt("%.3f", p99 * 1e3), fmt("%.3f", times.back() * 1e3),
                 fmt("%.1f", kTileSamples / med / 1e6), ok ? "yes" : "NO"});
    gen_series.points.push_back({double(mip), med * 1e3});
  }

  // --- Slopes: the refined world at three resolutions, the old default, real DEMs. ---
  Table slopes("slopes", {"terrain", "spacing m", "samples", "mean deg", "median", "p90", "p99", "<2", "2-5",
                          "5-10", "10-15", "15-20", "20-30", "30-40", "40-50", ">=50"});
  const auto add_row = [&](const std::string& name, double spacing, const SlopeStats& s) {
    std::vector<std::string> row = {name,
                                    fmt("%.1f", spacing),
                                    std::to_string(s.n),
                                    fmt("%.1f", s.mean),
                                    fmt("%.1f", s.p50),
                                    fmt("%.1f", s.p90),
                                    fmt("%.1f", s.p99)};
    for (double h : s.hist) row.push_back(fmt("%.3f", h));
    slopes.add_row(row);
  };
  // Sample windows spread over the whole refined world (land and sea floor alike).
  for (int32_t mip : {0, 3, 6}) {
    std::vector<double> all;
    const int windows = ctx.quick ? 2 : 24;
    const int64_t side = 256;
    for (int i = 0; i < windows; ++i) {
      lcg = lcg * 6364136223846793005ull + 1442695040888963407ull;
      const int64_t wx = int64_t((lcg >> 33) % uint64_t((w.base.width() >> mip) - side));
      const int64_t wy = int64_t((lcg >> 13) % uint64_t((w.base.height() >> mip) - side));
      add_slopes(refined_field(w, mip, {wx, wy, wx + side, wy + side}), all);
    }
    add_row("refined default, mip " + std::to_string(mip), std::ldexp(1.0, mip), stats_of(std::move(all)));
  }
  if (auto old = load_default_terrain(); old) {
    const World& ow = old->world;
    const RectI r = ow.params().sample_rect();
    Field f{"", r.width(), r.height(), ow.params().meters_per_sample, ow.params().meters_per_sample, {}};
    std::vector<uint16_t> q(size_t(r.area()));
    ow.read_coarse(r, q);
    for (uint16_t v : q) f.z.push_back(ow.params().height_meters(v));
    std::vector<double> s;
    add_slopes(f, s);
    add_row("old default (crop at 2 m)", f.dx, stats_of(std::move(s)));
  }
  int shared_rows = 0;
  for (const char* name : {"msh_crater_2004-10-04", "kilauea_utm30m_857x793", "jacksboro_3s_403x344",
                           "frontrange_srtm3_758", "rockies_30s_600"}) {
    const std::string path = ctx.shared_data_dir + "/" + name + ".png";
    if (!fs::exists(path)) continue;
    auto dem = read_dem_file(path);
    if (!dem) continue;
    Field f{
        name,       dem->width, dem->height, dem->meters_per_sample, dem->meters_per_sample * dem->anisotropy,
        dem->meters};
    for (double& z : f.z)
      if (!std::isfinite(z)) z = 0;
    std::vector<double> s;
    add_slopes(f, s);
    add_row(std::string(name) + " (real)", std::sqrt(f.dx * f.dy), stats_of(std::move(s)));
    ++shared_rows;
  }
  if (shared_rows == 0) {
    std::printf("world-scale: SKIPPING real DEMs: %s is absent\n", ctx.shared_data_dir.c_str());
    report.paragraph("**Real DEMs skipped**: `" + ctx.shared_data_dir + "` is absent.");
  }

  // --- Hillshades: 512^2 samples at 1 m and 4 m on the Himalayan front, the whole world at 128 m. ---
  fs::create_directories(ctx.out_dir);
  const int64_t hs = ctx.quick ? 256 : 512;
  const int64_t cx = w.base.width() * 45 / 100, cy = w.base.height() * 30 / 100;
  const bool hs_ok =
      write_hillshade(
          refined_field(w, 2,
                        {(cx >> 2) - hs / 2, (cy >> 2) - hs / 2, (cx >> 2) + hs / 2, (cy >> 2) + hs / 2}),
          ctx.out_dir + "/world_scale_hillshade_4m.png") &&
      write_hillshade(refined_field(w, 0, {cx - hs / 2, cy - hs / 2, cx + hs / 2, cy + hs / 2}),
                      ctx.out_dir + "/world_scale_hillshade_1m.png") &&
      write_hillshade(refined_field(w, 7, {0, 0, w.base.width() >> 7, w.base.height() >> 7}),
                      ctx.out_dir + "/world_scale_hillshade_128m.png");
  if (!hs_ok) {
    std::fprintf(stderr, "world-scale: could not write the hillshades\n");
    ++failures;
  }

  report.paragraph(
      "The refined default world: " + w.description + ", " + std::to_string(w.params.tiles_x) + " x " +
      std::to_string(w.params.tiles_y) + " tiles, " + std::to_string(mips) +
      " mips. Untouched tiles are generated, never stored or sent (docs/world.md, \"Refined "
      "worlds\"). Generation time of one 256^2 tile per mip on one core, over tiles drawn across "
      "the world; mips at and above 7 are the crop itself.");
  report.table(gen);
  report.plot(Plot{"world_scale_tile_time.png",
                   "Refined tile generation",
                   "mip",
                   "ms per 256^2 tile",
                   false,
                   false,
                   {gen_series},
                   {{"target 1 ms", 1.0}}});
  report.paragraph(
      "Slope histograms (Horn's method, degrees; fraction of samples per bin) of the refined world over "
      "256^2 windows spread across it (land and sea floor alike), at 1, 8 and 64 m, beside real DEMs at "
      "their own resolution and the old default (the same crop squeezed to 2 m per sample). Hillshades: "
      "![1 m](world_scale_hillshade_1m.png) 512 m at 1 m, ![4 m](world_scale_hillshade_4m.png) 2 km at 4 m "
      "(both on the Himalayan front), ![128 m](world_scale_hillshade_128m.png) the whole world at 128 m.");
  report.table(slopes);

  // --- Importing a DEM of 32768^2 samples into a tile pack, in bounded memory. ---
  const std::string work =
      (fs::temp_directory_path() / ("loam_bench_world_scale_pack_" + std::to_string(::getpid()))).string();
  const int64_t import_side = ctx.quick ? 2048 : 32768;
  const PackImportBench imp = bench_pack_import(ctx, work, import_side, !ctx.quick);
  if (!imp.ran) {
    std::printf("world-scale: SKIPPING the pack import: %s\n", imp.note.c_str());
    report.paragraph("**Pack import skipped**: " + imp.note);
    if (fs::exists(ctx.shared_data_dir)) ++failures;
  } else {
    const bool ok = ctx.sanitized || imp.peak_rss_mib <= 512.0;
    if (!ok) ++failures;
    Table t("import", {"source", "samples", "16-bit MiB", "generated in s", "import s", "MiB/s", "Msamples/s",
                       "peak RSS MiB", "bound", "pack MiB", "bits/sample", "tiles (every mip)"});
    const double ms = double(imp.side) * double(imp.side) / 1e6;
    t.add_row({"GeoTIFF, " + imp.layout + ", uint16 (ETOPO5 window resampled)",
               std::to_string(imp.side) + "^2", fmt("%.0f", imp.source_mib), fmt("%.1f", imp.generate_s),
               fmt("%.1f", imp.import_s), fmt("%.1f", imp.source_mib / imp.import_s),
               fmt("%.1f", ms / imp.import_s), fmt("%.0f", imp.peak_rss_mib), "512",
               fmt("%.1f", double(imp.pack_bytes) / double(1 << 20)),
               fmt("%.2f", double(imp.pack_bytes) * 8.0 / (double(imp.side) * double(imp.side))),
               std::to_string(imp.pack_tiles)});
    report.paragraph(
        "`loam-server import DEM --pack FILE.loampack`, a separate process (peak RSS from wait4), on a "
        "GeoTIFF "
        "the suite generates with `gdal_translate` from the shared ETOPO5 (a 1024^2 window over Asia "
        "resampled "
        "bilinearly; deleted afterwards, never committed). The importer reads the raster twice in strips (a "
        "scan for the quantization, then quantize, build every mip and encode each tile as soon as its rows "
        "are in): memory is about 2 x 256 world rows plus one strip, whatever the raster's height. Time "
        "includes both passes and the fsync; throughput is of 16-bit source samples.");
    report.table(t);
    std::printf("  import: %lld^2 in %.1f s (%.0f MiB/s), peak RSS %.0f MiB, pack %.1f MiB\n",
                (long long)imp.side, imp.import_s, imp.source_mib / imp.import_s, imp.peak_rss_mib,
                double(imp.pack_bytes) / double(1 << 20));
  }

  // --- Serving the refined world, then the imported pack, to roaming bots and viewers. ---
  const uint64_t cache_mb = ctx.quick ? 16 : 256;
  const int bots = ctx.quick ? 2 : 16, viewer_count = ctx.quick ? 1 : 2;
  const double serve_s = ctx.quick ? 8.0 : 300.0;
  struct Served {
    std::string world;
    ServeResult r;
  };
  std::vector<Served> served;
  // Quick runs (CI) snapshot at every MiB of changed tiles, so edited tiles are evicted to the
  // store and read back while the bots check every hash.
  const std::vector<std::string> evict =
      ctx.quick ? std::vector<std::string>{"--snapshot-dirty-mb", "1"} : std::vector<std::string>{};
  std::vector<std::string> refined_args = {"--terrain", "refined"}, pack_args = {"--dem", imp.pack_path};
  refined_args.insert(refined_args.end(), evict.begin(), evict.end());
  pack_args.insert(pack_args.end(), evict.begin(), evict.end());
  served.push_back({"refined default, 512x384 tiles", serve_world(refined_args, bots, viewer_count, serve_s,
                                                                  2.0, cache_mb, true, !ctx.quick, true)});
  if (imp.ran) {
    const int tiles = int(imp.side / 256);
    served.push_back(
        {"imported pack, " + std::to_string(tiles) + "x" + std::to_string(tiles) + " tiles",
         serve_world(pack_args, bots, viewer_count, serve_s, 2.0, cache_mb, false, false, false)});
  }
  fs::remove_all(work);
  Table serve("serving",
              {"world", "roaming bots", "seconds", "stamps accepted", "bots converged (exit 0)",
               "server peak RSS MiB", "--cache-mb", "bound (cache + 256)", "bot peak RSS MiB (max)",
               "tick p50 ms", "tick p99 ms", "ticks over 33 ms %", "server bytes out"});
  Table viewers("viewers",
                {"world", "headless viewers (--lod classic, n = 255)", "converged (exit 0)",
                 "peak RSS MiB (max)", "bound", "GPU terrain MiB (max)", "bound", "CPU terrain MiB (max)"});
  const ServeResult* refined_run = nullptr;
  for (const Served& s : served) {
    const ServeResult& sr = s.r;
    if (!sr.ran) {
      std::printf("world-scale: SKIPPING serving %s: %s\n", s.world.c_str(), sr.note.c_str());
      report.paragraph("**Serving " + s.world + " skipped**: " + sr.note);
      continue;
    }
    if (&s == &served.front()) refined_run = &sr;
    // Sanitizers inflate memory several times: a sanitized run checks convergence only.
    const bool ok = sr.bots_ok == sr.bots && sr.viewers_ok == sr.viewers &&
                    (ctx.sanitized || (sr.server_rss_mib <= double(cache_mb) + 256.0 &&
                                       sr.viewer_rss_max_mib <= 1024.0 && sr.viewer_gpu_max_mib <= 256.0));
    if (!ok) ++failures;
    serve.add_row({s.world, std::to_string(sr.bots), fmt("%.0f", sr.seconds), std::to_string(sr.accepted),
                   std::to_string(sr.bots_ok) + "/" + std::to_string(sr.bots), fmt("%.0f", sr.server_rss_mib),
                   std::to_string(cache_mb), fmt("%.0f", double(cache_mb) + 256.0),
                   fmt("%.0f", sr.bot_rss_max_mib), fmt("%.2f", sr.tick_p50_ms), fmt("%.2f", sr.tick_p99_ms),
                   fmt("%.2f", sr.overrun_pct), std::to_string(sr.bytes_out)});
    viewers.add_row({s.world, std::to_string(sr.viewers),
                     std::to_string(sr.viewers_ok) + "/" + std::to_string(sr.viewers),
                     fmt("%.0f", sr.viewer_rss_max_mib), "1024", fmt("%.1f", sr.viewer_gpu_max_mib), "256",
                     fmt("%.1f", sr.viewer_cpu_max_mib)});
    std::printf(
        "  serving %s: %d/%d bots and %d/%d viewers converged, server peak %.0f MiB, bot peak %.0f MiB, "
        "viewer "
        "peak %.0f MiB (GPU terrain %.1f MiB), tick p99 %.2f ms\n",
        s.world.c_str(), sr.bots_ok, sr.bots, sr.viewers_ok, sr.viewers, sr.server_rss_mib,
        sr.bot_rss_max_mib, sr.viewer_rss_max_mib, sr.viewer_gpu_max_mib, sr.tick_p99_ms);
  }
  if (serve.rows() > 0) {
    report.paragraph(
        "A `loam-server serve` process (`--terrain refined`, or `--dem PACK` on the imported pack) and "
        "roaming "
        "`loam-client bot --roam 30` processes (30 m/s loops, 2 stamps/s each near themselves, subscribing "
        "by "
        "distance as a viewer does, checking every held tile's hash; exit 0 = every stamp accepted, 0 "
        "mismatches). On the refined world the bots generate untouched tiles themselves (Welcome names the "
        "base) and download only edited ones; on the pack they cannot generate the base, so every tile they "
        "subscribe comes from the server within their 128 KiB/s byte budget. The server holds the terrain's "
        "tiles (the base's, and edited ones) within `--cache-mb`; edited tiles no snapshot holds count in "
        "it, and a snapshot is due when they reach `--snapshot-dirty-mb` (16). Peak RSS from /proc "
        "(server) and wait4 (bots). Tick p50/p99 are over the server's last stats period (its Stats "
        "message), the overrun share over the whole run. Every process shares the machine's hardware "
        "threads (the viewers render with llvmpipe on them), so tick times include waiting for a core; the "
        "server's `tick_overrun` lines say where a long tick went.");
    report.table(serve);
    report.paragraph(
        "`loam-client view --headless --n 255` processes in the same sessions, orbiting 1.5 km around the "
        "centre and stamping where they look every 2 s. Exit 0 = no hash mismatch and no GPU/CPU "
        "divergence. GPU terrain memory is the clipmap's level textures plus the display's tile pages "
        "(gpu/tile_pages.h); CPU terrain memory is the confirmed store's and the display's held tiles. Peak "
        "RSS from wait4; llvmpipe's own buffers are in it.");
    report.table(viewers);
  }
  if (refined_run) {
    const ServeResult& sr = *refined_run;
    if (sr.flight_ran) {
      Table flight("flight", {"viewer", "seconds", "frames", "frames with a level on a coarser mip %",
                              "frames waiting over 0.5 s %", "bound %", "longest wait s", "exit 0"});
      flight.add_row({"`--fly 300` (the default viewer)", fmt("%.0f", sr.flight_seconds),
                      std::to_string(sr.flight_frames), fmt("%.2f", sr.flight_lacking_pct),
                      fmt("%.2f", sr.flight_waiting_pct), "1", fmt("%.2f", sr.flight_longest_s),
                      sr.flight_ok ? "yes" : "no"});
      report.paragraph(
          "A headless viewer flying a loop at 300 m/s, 120 m above the ground, in the refined session. A "
          "frame "
          "counts when any clipmap level's region lacks a tile of the level's own mip (it shows a coarser "
          "mip "
          "there); the wait is how long that level has lacked it. The viewer generates untouched tiles as it "
          "subscribes them (0.25 ms each) and downloads only edited ones, within its byte budget.");
      report.table(flight);
      if (!sr.flight_ok || sr.flight_waiting_pct > 1.0) ++failures;
    }
    Table joins("join", {"client", "whole-world coarse view (tiles, mips 6+)", "held after s",
                         "region chunks received"});
    joins.add_row({"generates the base", std::to_string(sr.view_tiles), fmt("%.3f", sr.join_generated_s),
                   std::to_string(sr.join_generated_chunks)});
    if (sr.join_downloaded_s >= 0)  // not in quick runs: about 35 s at 128 KiB/s
      joins.add_row({"downloads the base (no provider)", std::to_string(sr.view_tiles),
                     fmt("%.3f", sr.join_downloaded_s), std::to_string(sr.join_downloaded_chunks)});
    report.paragraph(
        "Joining the refined world at 128 KiB/s (`--client-budget`): time from connect until every tile "
        "of mips 6 and up (the whole world, 64 m per sample and coarser) is held.");
    report.table(joins);
    if (!ctx.sanitized && !(sr.join_generated_s >= 0 && sr.join_generated_s <= 1.0)) ++failures;
  }

  // --- Incremental snapshots and retention over a long session. ---
  const uint64_t snap_stamps = ctx.quick ? 6000 : 1000000, snap_every = ctx.quick ? 1500 : 10000;
  const uint32_t keep = ctx.quick ? 2 : 3;
  const uint64_t log_cap = ctx.quick ? (uint64_t(64) << 10) : (uint64_t(16) << 20);
  const SnapshotBench sb = bench_snapshots(ctx, snap_stamps, snap_every, keep, log_cap);
  if (!sb.ran) {
    std::printf("world-scale: snapshots FAILED: %s\n", sb.note.c_str());
    report.paragraph("**Snapshots failed**: " + sb.note);
    ++failures;
  } else {
    Table snaps("snapshots", {"after stamps", "tiles changed since the last", "their records MiB",
                              "snapshot wrote MiB", "written / changed", "compaction moved MiB", "index KiB",
                              "write s", "live tiles MiB", "log MiB", "snapshots MiB", "data folder MiB"});
    Series dir_series{"data folder MiB", {}}, log_series{"log MiB", {}}, snap_series{"snapshots MiB", {}},
        live_series{"live tiles MiB", {}};
    uint64_t max_dir = 0;
    const size_t n = sb.rounds.size();
    for (size_t i = 0; i < n; ++i) {
      const SnapshotRound& rd = sb.rounds[i];
      const double mib = double(1 << 20);
      dir_series.points.push_back({double(rd.stamps), double(rd.data_dir_bytes) / mib});
      log_series.points.push_back({double(rd.stamps), double(rd.log_bytes) / mib});
      snap_series.points.push_back({double(rd.stamps), double(rd.snapshot_bytes) / mib});
      live_series.points.push_back({double(rd.stamps), double(rd.live_bytes) / mib});
      max_dir = std::max(max_dir, rd.data_dir_bytes);
      // The first rounds, then every tenth, and the last.
      if (i < 3 || (i + 1) % 10 == 0 || i + 1 == n)
        snaps.add_row({std::to_string(rd.stamps), std::to_string(rd.tiles_written),
                       fmt("%.2f", double(rd.tile_bytes) / mib), fmt("%.2f", double(rd.written_bytes) / mib),
                       fmt("%.3f", rd.tile_bytes ? double(rd.written_bytes) / double(rd.tile_bytes) : 0.0),
                       fmt("%.2f", double(rd.moved_bytes) / mib),
                       fmt("%.1f", double(rd.index_bytes) / 1024.0), fmt("%.3f", rd.write_s),
                       fmt("%.1f", double(rd.live_bytes) / mib), fmt("%.1f", double(rd.log_bytes) / mib),
                       fmt("%.1f", double(rd.snapshot_bytes) / mib),
                       fmt("%.1f", double(rd.data_dir_bytes) / mib)});
    }
    if (sb.worst_ratio > 2.0) ++failures;
    report.paragraph(
        "A session on the refined world driven in-process (the server's TerrainState and Storage, no "
        "network): " +
        std::to_string(sb.stamps) +
        " stamps by 16 players roaming at 30 m/s and stamping near "
        "themselves (the bots' mix: craters, gaussians on both layers, footprints; " +
        fmt("%.0f", sb.stamps_per_s) + " stamps/s applied, logged and synced per 64), a snapshot every " +
        std::to_string(sb.every) +
        " stamps. Each snapshot writes the tiles changed since the previous one "
        "(all mips and the detail layer; records are the tile's header and its fast-mode codec payload), "
        "the live records of sparse files (compaction, within the changed bytes), and a full index of the "
        "edited tiles. Retention: the newest " +
        std::to_string(sb.keep_snapshots) +
        " snapshots, and log segments they cover removed while the log exceeds " +
        fmt("%.2f", double(sb.log_cap_bytes) / double(1 << 20)) +
        " MiB (`--keep-snapshots`, `--log-retention-mb`). Worst written / changed over every snapshot: " +
        fmt("%.3f", sb.worst_ratio) + " (bound 2). Largest data folder: " +
        fmt("%.1f", double(max_dir) / double(1 << 20)) + " MiB with " + std::to_string(sb.edited_tiles) +
        " edited tiles at the end. A restart (recovery: the newest snapshot's index, every tile it names "
        "decoded and checked, then " +
        std::to_string(sb.restart_replayed) + " log records replayed) took " + fmt("%.2f", sb.restart_s) +
        " s.");
    report.table(snaps);
    report.plot(Plot{"world_scale_data_dir.png",
                     "Data folder over a long session",
                     "stamps",
                     "MiB",
                     false,
                     false,
                     {dir_series, snap_series, live_series, log_series},
                     {}});
    std::printf(
        "  snapshots: %zu, worst written/changed %.3f, largest data folder %.1f MiB, restart %.2f s\n", n,
        sb.worst_ratio, double(max_dir) / double(1 << 20), sb.restart_s);
  }
  return failures;
}

}  // namespace

// Registered by hand: the suite's name has a hyphen.
static SuiteRegistration world_scale_registration(
    "world-scale", "worlds of tens of km: refined tile generation time, slopes against real DEMs",
    run_world_scale);

}  // namespace loam::bench
