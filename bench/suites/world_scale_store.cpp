#include "bench/suites/world_scale_store.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "client/controls/roam_path.h"
#include "protocol/log/log_format.h"
#include "protocol/stamps/stamp_mix.h"
#include "server/storage.h"
#include "tests/support/child_process.h"

namespace loam::bench {
namespace {

namespace fs = std::filesystem;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Runs a program to completion with its output in `log`; exit status and peak RSS (MiB).
struct Ran {
  bool ok = false;
  double seconds = 0, peak_rss_mib = 0;
};
Ran run(std::vector<std::string> args, const std::string& log) {
  const auto t0 = std::chrono::steady_clock::now();
  const test::ChildExit e = test::wait_child(test::spawn_child(std::move(args), log, log));
  return Ran{e.ok(), seconds_since(t0), e.peak_rss_mib};
}

std::string tail_of(const std::string& path) {
  std::ifstream in(path);
  std::string all{std::istreambuf_iterator<char>(in), {}};
  return all.size() > 400 ? all.substr(all.size() - 400) : all;
}

}  // namespace

PackImportBench bench_pack_import(const Context& ctx, const std::string& dir, int64_t side, bool tiled) {
  PackImportBench r;
  r.side = side;
  r.layout = tiled ? "tiled 256x256" : "striped";
  const std::string etopo = ctx.shared_data_dir + "/etopo5_global_4320x2161.png";
  if (!fs::exists(etopo)) {
    r.note = etopo + " is absent";
    return r;
  }
  fs::create_directories(dir);
  const std::string tif = dir + "/etopo5_asia_" + std::to_string(side) + ".tif";
  r.pack_path = dir + "/etopo5_asia_" + std::to_string(side) + ".loampack";
  fs::remove(tif);
  fs::remove(r.pack_path);
  // A 1024^2 window (60E..145E, 50N..35S: the Himalaya, Tibet, the Bay of Bengal and
  // Indonesia) resampled to side^2: 16-bit samples, uncompressed, as a user's DEM export.
  std::vector<std::string> gen = {"gdal_translate",
                                  "-q",
                                  "-of",
                                  "GTiff",
                                  "-srcwin",
                                  "2880",
                                  "480",
                                  "1024",
                                  "1024",
                                  "-outsize",
                                  std::to_string(side),
                                  std::to_string(side),
                                  "-r",
                                  "bilinear"};
  if (tiled) gen.insert(gen.end(), {"-co", "TILED=YES", "-co", "BLOCKXSIZE=256", "-co", "BLOCKYSIZE=256"});
  gen.insert(gen.end(), {"-co", "BIGTIFF=IF_NEEDED", etopo, tif});
  const Ran g = run(gen, dir + "/gdal_translate.log");
  if (!g.ok) {
    r.note = "gdal_translate failed: " + tail_of(dir + "/gdal_translate.log");
    return r;
  }
  r.generate_s = g.seconds;
  r.source_mib = double(side) * double(side) * 2.0 / double(1 << 20);
  // 9.27 km per source sample / 32 (at side 32768): about 290 m; heights as the PNG's sidecar
  // gives them (value - 10376 m).
  const double mps = 9276.7 * 1024.0 / double(side);
  const Ran imp = run({LOAM_SERVER_BINARY, "import", tif, "--pack", r.pack_path, "--meters-per-sample",
                       std::to_string(mps), "--vertical-scale", "1", "--vertical-offset", "-10376"},
                      dir + "/import.log");
  fs::remove(tif);  // 2 GiB at full size: never kept
  if (!imp.ok) {
    r.note = "import failed: " + tail_of(dir + "/import.log");
    return r;
  }
  r.import_s = imp.seconds;
  r.peak_rss_mib = imp.peak_rss_mib;
  std::error_code ec;
  r.pack_bytes = fs::file_size(r.pack_path, ec);
  std::ifstream log(dir + "/import.log");
  for (std::string line; std::getline(log, line);) {
    unsigned long long tiles = 0;
    if (std::sscanf(line.c_str(), "tiles %llu", &tiles) == 1) r.pack_tiles = tiles;
  }
  r.ran = true;
  return r;
}

SnapshotBench bench_snapshots(const Context& ctx, uint64_t stamps, uint64_t every, uint32_t keep_snapshots,
                              uint64_t log_cap_bytes) {
  (void)ctx;
  SnapshotBench r;
  r.stamps = stamps;
  r.every = every;
  r.keep_snapshots = keep_snapshots;
  r.log_cap_bytes = log_cap_bytes;
  const std::string dir =
      (fs::temp_directory_path() / ("loam_bench_snapshots_" + std::to_string(::getpid()))).string();
  fs::remove_all(dir);
  {
    auto opened = server::open_storage(dir, "", StampLimits{}, {}, {}, server::kTerrainRefined);
    if (!opened) {
      r.note = opened.error().describe();
      return r;
    }
    server::Storage& storage = opened->storage;
    server::TerrainState& terrain = opened->terrain;
    storage.set_retention({keep_snapshots, log_cap_bytes});
    World& world = terrain.mutable_world();
    world.set_base_cache_budget(size_t(256) << 20);
    const WorldParams& w = world.params();
    // 16 players walking loops at 30 m/s, 2 stamps a second each (the bots' mix and radii).
    constexpr int kPlayers = 16;
    RandomStampOptions o = random_stamp_options(w);
    o.kinds = {StampKind::kCrater, StampKind::kGaussian, StampKind::kGaussian, StampKind::kFootprint};
    o.blends = {BlendMode::kAdd, BlendMode::kSubtract};
    o.layer_share = {{3, 1}};
    o.layer_kinds[Layer::kDetail] = {StampKind::kGaussian};
    o.min_radius = 2.0;
    o.max_radius = 32.0;
    o.max_radius_of_kind[size_t(StampKind::kFootprint)] = 1.5;
    o.max_intensity[Layer::kCoarse] = 2.5;
    o.min_intensity[Layer::kCoarse] = 0.2;
    o.max_intensity[Layer::kDetail] = 0.25;
    StampRng rng(2026);
    const auto t0 = std::chrono::steady_clock::now();
    uint64_t tick = 0;
    for (uint64_t i = 1; i <= stamps; ++i) {
      const int player = int(i % kPlayers);
      const double t = double(i / kPlayers) * 0.5;  // each player stamps every 0.5 s
      const auto [x, y] = controls::roam_position(w, uint32_t(player + 1), 30.0, t);
      RandomStampOptions near = o;
      near.x0 = std::max(o.x0, x - 150.0), near.x1 = std::min(o.x1, x + 150.0);
      near.y0 = std::max(o.y0, y - 150.0), near.y1 = std::min(o.y1, y + 150.0);
      auto q = random_valid_stamp(rng, near, w);
      if (!q) continue;
      const uint64_t seq = terrain.last_seq() + 1;
      if (i % 64 == 0) ++tick;
      if (!storage.append(log::LogRecord{seq, tick, uint32_t(player + 1), *q}).ok()) {
        r.note = "log append failed";
        return r;
      }
      auto applied = terrain.apply(*q, seq, uint32_t(player + 1));
      if (!applied) {
        r.note = applied.error().describe();
        return r;
      }
      if (i % 64 == 0) {
        if (!storage.sync().ok()) {
          r.note = "log sync failed";
          return r;
        }
        world.trim_base_cache();
      }
      if (i % every == 0) {
        auto snap = storage.snapshot(terrain, tick);
        if (!snap) {
          r.note = snap.error().describe();
          return r;
        }
        world.trim_base_cache();
        SnapshotRound round;
        round.stamps = i;
        round.tiles_written = snap->write.tiles_written;
        round.tile_bytes = snap->write.tile_bytes;
        round.written_bytes = snap->write.written_bytes;
        round.moved_bytes = snap->write.moved_bytes;
        round.index_bytes = snap->write.index_bytes;
        round.write_s = snap->write.seconds;
        round.log_bytes = storage.log_bytes();
        round.snapshot_bytes = storage.snapshot_bytes();
        round.data_dir_bytes = server::folder_bytes(dir);
        round.live_bytes = storage.store().live_bytes();
        if (round.tile_bytes > 0)
          r.worst_ratio = std::max(r.worst_ratio, double(round.written_bytes) / double(round.tile_bytes));
        r.rounds.push_back(round);
      }
    }
    r.stamps_per_s = double(stamps) / seconds_since(t0);
    if (!storage.sync().ok()) {
      r.note = "log sync failed";
      return r;
    }
    r.edited_tiles = world.edited_tiles().size();
  }
  // A restart: the newest snapshot plus the log after it.
  const auto t1 = std::chrono::steady_clock::now();
  auto reopened = server::open_storage(dir, "", StampLimits{}, {}, {}, server::kTerrainRefined);
  r.restart_s = seconds_since(t1);
  if (!reopened) {
    r.note = "restart failed: " + reopened.error().describe();
    return r;
  }
  r.restart_replayed = reopened->report.replayed_records;
  fs::remove_all(dir);
  r.ran = true;
  return r;
}

}  // namespace loam::bench
