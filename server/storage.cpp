#include "server/storage.h"

#include <algorithm>
#include <chrono>
#include <filesystem>

#include "dem/stamp_texture_io.h"
#include "protocol/snapshot/snapshot.h"
#include "server/terrain_source.h"

namespace loam::server {
namespace fs = std::filesystem;

namespace {

uint64_t now_unix_us() {
  return uint64_t(std::chrono::duration_cast<std::chrono::microseconds>(
                      std::chrono::system_clock::now().time_since_epoch())
                      .count());
}

}  // namespace

std::vector<std::string> list_segments(const std::string& data_dir) {
  std::vector<std::string> out;
  std::error_code ec;
  const fs::path dir = fs::path(data_dir) / "log";
  if (!fs::is_directory(dir, ec)) return out;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("segment-", 0) == 0 && e.path().extension() == ".loamlog")
      out.push_back(e.path().string());
  }
  std::sort(out.begin(), out.end());  // zero-padded indices sort numerically
  return out;
}

struct StorageOpener {
  static Status register_images(TerrainState& terrain, const std::vector<std::string>& files) {
    for (const std::string& f : files) {
      auto id = register_stamp_texture_file(terrain.textures(), f);
      if (!id) return id.error();
    }
    return {};
  }

  static Result<OpenedStorage> open(const std::string& data_dir, const std::string& dem_path,
                                    const StampLimits& limits, const std::vector<std::string>& stamp_images,
                                    int dem_band) {
    std::error_code ec;
    fs::create_directories(fs::path(data_dir) / "log", ec);
    if (ec) return make_error(ErrorCode::kIo, data_dir, "cannot create the data folder: " + ec.message());
    RecoveryReport report;
    Storage storage;
    storage.data_dir_ = data_dir;
    const std::vector<std::string> segments = list_segments(data_dir);

    if (segments.empty()) {
      if (!list_snapshots(data_dir).empty()) {
        return make_error(ErrorCode::kCorrupt, data_dir,
                          "snapshots without a log: refusing to guess the session");
      }
      log::InitialTerrain initial;
      auto world = load_initial_terrain(dem_path, &initial, dem_band);
      if (!world) return world.error();
      log::SegmentHeader h;
      h.world = world->params();
      h.initial = initial;
      h.created_unix_us = now_unix_us();
      h.segment_index = 0;
      h.base_world_hash = initial.world_hash;
      const std::string path = (fs::path(data_dir) / "log" / log::segment_file_name(0)).string();
      auto writer = log::LogWriter::create(path, h);
      if (!writer) return writer.error();
      storage.writer_.emplace(std::move(*writer));
      storage.initial_ = initial;
      TerrainState terrain(std::move(*world), 0, limits);
      LOAM_TRY(register_images(terrain, stamp_images));
      return OpenedStorage{std::move(storage), std::move(terrain), report};
    }

    report.fresh = false;
    report.segments = segments.size();
    auto recovered = log::recover_segment(segments.back());
    if (!recovered) return recovered.error();
    if (recovered->removed_bytes > 0) {
      report.truncated_bytes = recovered->removed_bytes;
      report.damage = recovered->damage + " (truncated " + std::to_string(recovered->removed_bytes) +
                      " bytes at offset " + std::to_string(recovered->truncated_at) + " of " +
                      segments.back() + ")";
    }
    auto scans = log::read_log(segments);
    if (!scans) return scans.error();
    const log::InitialTerrain initial = scans->front().header.header.initial;
    const uint64_t log_last = scans->back().last_seq();

    // Newest valid snapshot that the log reaches.
    std::optional<LoadedSnapshot> snap;
    for (const std::string& path : list_snapshots(data_dir)) {
      auto loaded = read_snapshot(path);
      if (!loaded) {
        report.skipped.push_back(path + ": " + loaded.error().describe());
        continue;
      }
      if (loaded->manifest.last_seq > log_last) {
        report.skipped.push_back(path + ": beyond the log's last sequence " + std::to_string(log_last));
        continue;
      }
      snap.emplace(std::move(*loaded));
      break;
    }
    World world = [&]() -> World {
      if (snap) return std::move(snap->world);
      return World(scans->front().header.header.world, 0);
    }();
    uint64_t base = 0;
    if (snap) {
      base = snap->manifest.last_seq;
      report.snapshot_path = snap->path;
      report.snapshot_seq = base;
    } else {
      auto initial_world = load_described_terrain(initial, data_dir);
      if (!initial_world) return initial_world.error();
      world = std::move(*initial_world);
    }
    TerrainState terrain(std::move(world), base, limits);
    if (snap) {
      for (const StampTexture& t : snap->textures) {
        auto id = terrain.textures().add(t.width, t.height, t.samples);
        if (!id) return id.error();
      }
    }
    LOAM_TRY(register_images(terrain, stamp_images));
    for (const log::SegmentScan& scan : *scans) {
      for (const log::LogRecord& r : scan.records) {
        if (r.global_seq <= base) continue;
        if (r.global_seq != terrain.last_seq() + 1) {
          return make_error(ErrorCode::kCorrupt, "log",
                            "sequence gap: expected " + std::to_string(terrain.last_seq() + 1) + ", found " +
                                std::to_string(r.global_seq));
        }
        (void)terrain.apply(r.stamp, r.global_seq, r.client_id);  // a failing stamp is a no-op, as live
        ++report.replayed_records;
      }
    }
    report.last_seq = terrain.last_seq();
    auto writer = log::LogWriter::open_append(segments.back());
    if (!writer) return writer.error();
    storage.writer_.emplace(std::move(*writer));
    storage.initial_ = initial;
    storage.last_snapshot_seq_ = snap ? base : 0;
    return OpenedStorage{std::move(storage), std::move(terrain), report};
  }
};

Result<OpenedStorage> open_storage(const std::string& data_dir, const std::string& dem_path,
                                   const StampLimits& limits, const std::vector<std::string>& stamp_images,
                                   int dem_band) {
  return StorageOpener::open(data_dir, dem_path, limits, stamp_images, dem_band);
}

Result<std::string> Storage::snapshot(const TerrainState& terrain) {
  LOAM_TRY(writer_->sync());
  const uint32_t next = writer_->header().segment_index + 1;
  auto path = write_snapshot(data_dir_, terrain.world(), terrain.last_seq(), next, terrain.textures());
  if (!path) return path.error();
  log::SegmentHeader h;
  h.world = terrain.world().params();
  h.initial = initial_;
  h.created_unix_us = now_unix_us();
  h.segment_index = next;
  h.base_seq = terrain.last_seq();
  h.base_snapshot_id = terrain.last_seq();
  h.base_world_hash = terrain.world().world_hash();
  h.prev_header_checksum = writer_->header_checksum();
  const std::string seg = (fs::path(data_dir_) / "log" / log::segment_file_name(next)).string();
  auto writer = log::LogWriter::create(seg, h);
  if (!writer) return writer.error();
  writer_.emplace(std::move(*writer));
  last_snapshot_seq_ = terrain.last_seq();
  return path;
}

}  // namespace loam::server
