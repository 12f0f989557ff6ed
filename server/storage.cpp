#include "server/storage.h"

#include <sys/statvfs.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>

#include "dem/stamp_texture_io.h"
#include "protocol/snapshot/snapshot.h"
#include "server/stamp_image_store.h"
#include "server/terrain_source.h"

namespace loam::server {
namespace fs = std::filesystem;

namespace {

uint64_t now_unix_us() {
  return uint64_t(std::chrono::duration_cast<std::chrono::microseconds>(
                      std::chrono::system_clock::now().time_since_epoch())
                      .count());
}

// Only the header of a segment (recovery picks where to start before reading records).
Result<log::DecodedHeader> read_segment_header(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return make_error(ErrorCode::kNotFound, path, "cannot open");
  std::vector<uint8_t> bytes(12 + log::kMaxHeaderBodyBytes + 8);
  in.read(reinterpret_cast<char*>(bytes.data()), std::streamsize(bytes.size()));
  bytes.resize(size_t(in.gcount()));
  auto h = log::decode_segment_header(bytes);
  if (!h) {
    Error e = h.error();
    e.message = path + ": " + e.message;
    return e;
  }
  return h;
}

std::string describe_record(const log::LogRecord& r, const std::string& segment) {
  return "record " + std::to_string(r.global_seq) + " (" + to_string(r.stamp.kind) + ", client " +
         std::to_string(r.client_id) + ", tick " + std::to_string(r.tick) + ") of " + segment;
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

Result<uint64_t> free_bytes(const std::string& path) {
  struct statvfs st {};
  if (::statvfs(path.c_str(), &st) != 0) return make_error(ErrorCode::kIo, path, "statvfs failed");
  return uint64_t(st.f_bavail) * uint64_t(st.f_frsize);
}

struct StorageOpener {
  // Registers the options' images and every image the folder holds, and stores the new ones.
  static Status register_images(TerrainState& terrain, const std::string& data_dir,
                                const std::vector<std::string>& files, RecoveryReport& report,
                                bool read_only = false) {
    const LoadedImages stored = load_stamp_images(data_dir, terrain.textures());
    report.images_loaded = stored.loaded;
    report.images_damaged = stored.damaged;
    for (const std::string& f : files) {
      auto id = register_stamp_texture_file(terrain.textures(), f);
      if (!id) return id.error();
    }
    if (read_only) return {};
    auto written = store_stamp_images(data_dir, terrain.textures());
    if (!written) return written.error();
    return {};
  }

  static std::string segment_path(const std::string& data_dir, uint32_t index) {
    return (fs::path(data_dir) / "log" / log::segment_file_name(index)).string();
  }

  // The last segment, recovered: a torn tail is cut off; a segment whose header never became
  // complete (a crash while it was created: it can hold no record) is removed.
  static Result<log::Recovery> recover_last(std::vector<std::string>& segments, RecoveryReport& report) {
    for (;;) {
      auto recovered = log::recover_segment(segments.back());
      if (recovered) return recovered;
      const Error& e = recovered.error();
      std::error_code ec;
      const uint64_t size = fs::file_size(segments.back(), ec);
      const bool torn_header = segments.size() > 1 && e.field.rfind("log.", 0) == 0 &&
                               (e.code == ErrorCode::kTruncated || size == 0);
      if (!torn_header) {
        if (e.field == "record.checksum" || e.code == ErrorCode::kCorrupt) {
          Error advice = e;
          advice.message +=
              ". Recovery does not drop written records by itself: inspect with `loam-server log dump`, "
              "then `loam-server log repair` to cut the segment at the damage";
          return advice;
        }
        return e;
      }
      report.damage += "removed " + segments.back() + " (" + std::to_string(size) +
                       " bytes, its header incomplete: a crash while it was created); ";
      fs::remove(segments.back(), ec);
      if (ec) return make_error(ErrorCode::kIo, segments.back(), "cannot remove: " + ec.message());
      segments.pop_back();
    }
  }

  // A folder without a log: a new session on the initial terrain, its segment 0 written.
  static Result<OpenedStorage> open_fresh(Storage storage, const std::string& data_dir,
                                          const std::string& dem_path, const StampLimits& limits,
                                          const std::vector<std::string>& stamp_images, const DemChoice& dem,
                                          const std::string& terrain_kind, bool read_only,
                                          RecoveryReport& report) {
    log::InitialTerrain initial;
    auto world = load_initial_terrain(dem_path, &initial, dem, terrain_kind);
    if (!world) return world.error();
    if (initial.import_params == kPackImportParams && !read_only)
      LOAM_TRY(keep_pack_in_session(dem_path, data_dir));
    TerrainState terrain(std::move(*world), 0, limits);
    LOAM_TRY(register_images(terrain, data_dir, stamp_images, report));
    log::SegmentHeader h;
    h.world = terrain.world().params();
    h.initial = initial;
    h.created_unix_us = now_unix_us();
    h.segment_index = 0;
    h.base_world_hash = initial.world_hash;
    h.limits = limits;
    auto writer = log::LogWriter::create(segment_path(data_dir, 0), h);
    if (!writer) return writer.error();
    storage.writer_.emplace(std::move(*writer));
    storage.initial_ = initial;
    return OpenedStorage{std::move(storage), std::move(terrain), report};
  }

  // The newest valid snapshot the log reaches, and the index of the segment that continues it
  // (0 and none: replay from the initial terrain). Snapshots passed over are reported.
  static std::pair<std::optional<LoadedSnapshot>, size_t> newest_snapshot(
      Storage& storage, const std::string& data_dir, const std::vector<std::string>& segments,
      uint64_t log_last, const log::InitialTerrain& last_initial, RecoveryReport& report) {
    std::optional<LoadedSnapshot> snap;
    size_t start = 0;
    for (const std::string& path : list_snapshots(data_dir)) {
      // A snapshot holds the edits of a base it names; rebuild that base first.
      auto loaded = [&]() -> Result<LoadedSnapshot> {
        auto manifest = read_snapshot_manifest(path);
        if (!manifest) return manifest.error();
        auto snap_base = resolve_base(manifest->base_identity, last_initial, data_dir);
        if (!snap_base) return snap_base.error();
        // Incremental snapshots load through the session's store, which then continues them.
        if (manifest->format == kSnapshotFormatIncremental) return storage.store_->load(path, *snap_base);
        return read_snapshot(path, *snap_base);
      }();
      if (!loaded) {
        report.skipped.push_back(path + ": " + loaded.error().describe());
        continue;
      }
      if (loaded->manifest.last_seq > log_last) {
        report.skipped.push_back(path + ": beyond the log's last sequence " + std::to_string(log_last));
        continue;
      }
      std::optional<size_t> found;
      for (size_t i = segments.size(); i-- > 0;) {
        auto h = read_segment_header(segments[i]);
        if (h && h->header.base_seq <= loaded->manifest.last_seq) {
          found = i;
          break;
        }
      }
      if (!found) {
        report.skipped.push_back(path + ": no readable segment continues it");
        continue;
      }
      start = *found;
      snap.emplace(std::move(*loaded));
      break;
    }
    return {std::move(snap), start};
  }

  // Older segments are not needed; their damage is reported so an operator can archive them.
  static void report_older_damage(const std::vector<std::string>& segments, size_t start,
                                  RecoveryReport& report) {
    for (size_t i = 0; i < start; ++i) {
      auto scan = log::read_segment(segments[i]);
      if (!scan) {
        report.older_damage.push_back(scan.error().describe());
      } else if (scan->tail != log::TailState::kClean && scan->tail_error) {
        report.older_damage.push_back(segments[i] + ": " + scan->tail_error->describe());
      }
    }
  }

  // Every logged stamp after `base`, in sequence, under the limits its segment recorded; a gap
  // or a stamp that fails to apply stops the recovery.
  static Status replay_records(TerrainState& terrain, const std::vector<log::SegmentScan>& scans,
                               const std::vector<std::string>& needed, uint64_t base,
                               const StampLimits& limits, RecoveryReport& report) {
    for (size_t i = 0; i < scans.size(); ++i) {
      const log::SegmentScan& scan = scans[i];
      // What a logged stamp means is what it meant when it was accepted.
      terrain.set_limits(scan.header.header.has_limits ? scan.header.header.limits : limits);
      for (const log::LogRecord& r : scan.records) {
        if (r.global_seq <= base) continue;
        if (r.global_seq != terrain.last_seq() + 1) {
          return make_error(ErrorCode::kCorrupt, "log",
                            "sequence gap: expected " + std::to_string(terrain.last_seq() + 1) + ", found " +
                                std::to_string(r.global_seq));
        }
        auto applied = terrain.apply(r.stamp, r.global_seq, r.client_id);
        if (!applied) {
          return make_error(applied.error().code, "log",
                            describe_record(r, needed[i]) + " fails to apply: " + applied.error().describe() +
                                ". Recovery stops rather than serve a world without an acknowledged stamp");
        }
        ++report.replayed_records;
        // Clean tiles read by the replay go back under the cache budget as the server's ticks do.
        if (report.replayed_records % 256 == 0) terrain.mutable_world().trim_base_cache();
      }
    }
    return {};
  }

  // The writer that continues the log: the last segment appended to when it records these
  // limits, segment 0 rewritten when nothing was stamped yet, else a new segment (after a
  // snapshot) that records them.
  static Result<OpenedStorage> continue_log(Storage storage, TerrainState terrain,
                                            const std::vector<std::string>& segments,
                                            const log::SegmentScan& last, const StampLimits& limits,
                                            bool snapshot_reusable, RecoveryReport& report) {
    if (last.header.header.has_limits && last.header.header.limits == limits &&
        last.header.header.format_version == log::kLogFormatVersion) {
      auto writer = log::LogWriter::open_append(segments.back());
      if (!writer) return writer.error();
      storage.writer_.emplace(std::move(*writer));
      return OpenedStorage{std::move(storage), std::move(terrain), report};
    }
    // The options' limits differ from the recorded ones (or the log predates recording them):
    // a new segment records them before any new stamp is accepted under them.
    report.limits_changed = true;
    if (terrain.last_seq() == 0 && segments.size() == 1 && last.records.empty()) {
      // Nothing stamped yet: segment 0 is rewritten with the limits (the initial terrain's
      // description is unchanged; its hash now covers the parameters).
      log::SegmentHeader h = last.header.header;
      h.format_version = log::kLogFormatVersion;
      h.has_limits = true;
      h.limits = limits;
      h.initial.world_hash = h.base_world_hash = terrain.world().world_hash();
      storage.initial_ = h.initial;
      auto writer = log::LogWriter::create_replacing(segments.back(), h);
      if (!writer) return writer.error();
      storage.writer_.emplace(std::move(*writer));
      return OpenedStorage{std::move(storage), std::move(terrain), report};
    }
    auto writer = log::LogWriter::open_append(segments.back());
    if (!writer) return writer.error();
    storage.writer_.emplace(std::move(*writer));
    auto rolled = storage.snapshot(terrain, report.last_tick, /*reuse_existing=*/snapshot_reusable);
    if (!rolled) return rolled.error();
    return OpenedStorage{std::move(storage), std::move(terrain), report};
  }

  // The last segment recovered (read-only: its damaged tail left as it is, the records before it
  // counting); the log's last sequence.
  static Result<uint64_t> recover_tail(std::vector<std::string>& segments, bool read_only,
                                       RecoveryReport& report) {
    auto recovered = [&]() -> Result<log::Recovery> {
      if (!read_only) return recover_last(segments, report);
      auto scan = log::read_segment(segments.back());
      if (!scan) return scan.error();
      log::Recovery r;
      if (scan->tail_error) report.damage = "not repaired (read-only): " + scan->tail_error->describe();
      r.scan = std::move(*scan);
      return r;
    }();
    if (!recovered) return recovered.error();
    if (recovered->removed_bytes > 0) {
      report.truncated_bytes = recovered->removed_bytes;
      report.damage += recovered->damage + " (truncated " + std::to_string(recovered->removed_bytes) +
                       " bytes at offset " + std::to_string(recovered->truncated_at) + " of " +
                       segments.back() + ")";
    }
    return recovered->scan.last_seq();
  }

  // The world replay starts from: the snapshot's (with its images), else the initial terrain the
  // first needed segment describes.
  static Result<TerrainState> starting_terrain(std::optional<LoadedSnapshot>& snap,
                                               const log::SegmentHeader& first, const std::string& data_dir,
                                               const StampLimits& limits, RecoveryReport& report) {
    if (!snap) {
      auto initial_world = load_described_terrain(first.initial, first.world, data_dir);
      if (!initial_world) return initial_world.error();
      return TerrainState(std::move(*initial_world), 0, limits);
    }
    const uint64_t base = snap->manifest.last_seq;
    report.snapshot_path = snap->path;
    report.snapshot_seq = base;
    TerrainState terrain(std::move(snap->world), base, limits);
    for (const StampTexture& t : snap->textures) {
      auto id = terrain.textures().add(t.width, t.height, t.samples);
      if (!id) return id.error();
    }
    return terrain;
  }

  static Result<OpenedStorage> open(const std::string& data_dir, const std::string& dem_path,
                                    const StampLimits& limits, const std::vector<std::string>& stamp_images,
                                    const DemChoice& dem, const std::string& terrain_kind, bool read_only) {
    LOAM_TRY(validate_limits(limits));
    if (read_only) {
      if (list_segments(data_dir).empty())
        return make_error(ErrorCode::kNotFound, data_dir, "no session log here");
    }
    std::error_code ec;
    fs::create_directories(fs::path(data_dir) / "log", ec);
    if (ec) return make_error(ErrorCode::kIo, data_dir, "cannot create the data folder: " + ec.message());
    RecoveryReport report;
    if (!read_only) report.partial_snapshots_removed = remove_partial_snapshots(data_dir);
    Storage storage;
    storage.data_dir_ = data_dir;
    storage.store_ = SnapshotStore::open(data_dir);
    std::vector<std::string> segments = list_segments(data_dir);

    if (segments.empty()) {
      if (!list_snapshots(data_dir).empty()) {
        return make_error(ErrorCode::kCorrupt, data_dir,
                          "snapshots without a log: refusing to guess the session");
      }
      return open_fresh(std::move(storage), data_dir, dem_path, limits, stamp_images, dem, terrain_kind,
                        read_only, report);
    }

    report.fresh = false;
    auto log_last = recover_tail(segments, read_only, report);
    if (!log_last) return log_last.error();

    // The session's initial terrain (every segment's header repeats it): a snapshot's base may
    // be the tile pack it names.
    log::InitialTerrain last_initial;
    if (auto h = read_segment_header(segments.back())) last_initial = h->header.initial;
    // Newest valid snapshot that the log reaches, and the segment that continues it.
    auto [snap, start] = newest_snapshot(storage, data_dir, segments, *log_last, last_initial, report);
    const std::vector<std::string> needed(segments.begin() + ptrdiff_t(start), segments.end());
    auto scans = log::read_log(needed);
    if (!scans) return scans.error();
    if (read_only && scans->back().tail_error) {
      // read_log left the tail unrepaired; the records before it are what a restart replays.
      scans->back().tail = log::TailState::kClean;
    }
    report_older_damage(segments, start, report);
    report.segments = needed.size();
    report.segments_skipped = start;
    const log::SegmentHeader& first = scans->front().header.header;
    const log::InitialTerrain initial = first.initial;

    const uint64_t base = snap ? snap->manifest.last_seq : 0;
    auto started = starting_terrain(snap, first, data_dir, limits, report);
    if (!started) return started.error();
    TerrainState terrain = std::move(*started);
    LOAM_TRY(register_images(terrain, data_dir, stamp_images, report, read_only));
    LOAM_TRY(replay_records(terrain, *scans, needed, base, limits, report));
    report.last_seq = terrain.last_seq();
    const log::SegmentScan& last = scans->back();
    report.last_tick = std::max(last.last_tick, snap && snap->manifest.has_session ? snap->manifest.tick : 0);
    if (last.header.header.has_limits) report.recorded_limits = last.header.header.limits;
    storage.initial_ = initial;
    storage.last_snapshot_seq_ = snap ? base : 0;
    if (read_only) return OpenedStorage{std::move(storage), std::move(terrain), report};
    terrain.set_limits(limits);

    const bool snapshot_reusable = snap && base == terrain.last_seq();
    return continue_log(std::move(storage), std::move(terrain), segments, last, limits, snapshot_reusable,
                        report);
  }
};

Result<OpenedStorage> open_storage(const std::string& data_dir, const std::string& dem_path,
                                   const StampLimits& limits, const std::vector<std::string>& stamp_images,
                                   const DemChoice& dem, const std::string& terrain) {
  return StorageOpener::open(data_dir, dem_path, limits, stamp_images, dem, terrain, false);
}

Result<OpenedStorage> read_session(const std::string& data_dir) {
  return StorageOpener::open(data_dir, "", StampLimits{}, {}, {}, kTerrainCrop, true);
}

Status Storage::resume(uint64_t last_seq) {
  if (writer_->is_open()) return {};
  auto free = free_bytes(data_dir_);
  if (!free) return free.error();
  if (*free < kMinFreeBytes) {
    return make_error(
        ErrorCode::kIo, data_dir_,
        "no space: " + std::to_string(*free) + " bytes free, edits need " + std::to_string(kMinFreeBytes));
  }
  auto w = log::LogWriter::reopen_after_failure(writer_->path(), writer_->durable_bytes(), last_seq);
  if (!w) return w.error();
  writer_.emplace(std::move(*w));
  return {};
}

Storage::~Storage() {
  if (pending_ && pending_->worker.joinable()) pending_->worker.join();
}

Status Storage::roll_segment(const TerrainState& terrain, uint64_t tick, uint64_t created_unix_us) {
  LOAM_TRY(writer_->sync());
  const uint32_t next = writer_->header().segment_index + 1;
  log::SegmentHeader h;
  h.world = terrain.world().params();
  h.initial = initial_;
  h.created_unix_us = created_unix_us;
  h.segment_index = next;
  h.base_seq = terrain.last_seq();
  h.base_snapshot_id = terrain.last_seq();
  h.base_world_hash = terrain.world().world_hash();
  h.prev_header_checksum = writer_->header_checksum();
  h.limits = terrain.limits();
  h.base_tick = std::max(tick, writer_->last_tick());
  auto writer = log::LogWriter::create(segment_path_of(next), h);
  if (!writer) return writer.error();
  writer_.emplace(std::move(*writer));
  return {};
}

Result<SnapshotOutcome> Storage::snapshot(TerrainState& terrain, uint64_t tick, bool reuse_existing) {
  if (reuse_existing) {
    LOAM_TRY(roll_segment(terrain, tick, now_unix_us()));
    SnapshotOutcome out;
    out.write.path = (fs::path(data_dir_) / "snapshots" / snapshot_dir_name(terrain.last_seq())).string();
    out.write.last_seq = terrain.last_seq();
    last_snapshot_seq_ = terrain.last_seq();
    return out;
  }
  LOAM_TRY(begin_snapshot(terrain, tick, now_unix_us()));
  return *poll_snapshot(terrain, true);
}

Status Storage::begin_snapshot(TerrainState& terrain, uint64_t tick, uint64_t created_unix_us) {
  if (pending_) return make_error(ErrorCode::kInvalidArgument, data_dir_, "a snapshot is being written");
  LOAM_TRY(writer_->sync());
  const uint32_t next = writer_->header().segment_index + 1;
  SnapshotJobHandle job = store_->begin(terrain.world(), terrain.last_seq(), next, terrain.textures(),
                                        SnapshotSession{terrain.limits(), tick});
  // The records after this sequence go to the segment that continues the snapshot. Should the
  // snapshot fail, recovery reads on through it from the previous one.
  LOAM_TRY(roll_segment(terrain, tick, created_unix_us));
  last_snapshot_seq_ = terrain.last_seq();
  pending_ = std::make_unique<PendingSnapshot>(std::move(job));
  PendingSnapshot* p = pending_.get();
  p->worker = std::thread([p] {
    p->status = SnapshotStore::run(p->job);
    p->done = true;
  });
  return {};
}

std::optional<Result<SnapshotOutcome>> Storage::poll_snapshot(TerrainState& terrain, bool wait) {
  if (!pending_ || (!wait && !pending_->done)) return std::nullopt;
  pending_->worker.join();
  const std::unique_ptr<PendingSnapshot> p = std::move(pending_);
  if (!p->status.ok()) return Result<SnapshotOutcome>(p->status.error());
  auto written = store_->finish(terrain.mutable_world(), std::move(p->job));
  if (!written) return Result<SnapshotOutcome>(written.error());
  SnapshotOutcome out;
  out.write = *written;
  apply_retention(out);
  return Result<SnapshotOutcome>(std::move(out));
}

void Storage::apply_retention(SnapshotOutcome& out) {
  // A failure here loses nothing (the snapshot and the log are in place): it is retried after
  // the next snapshot.
  auto pruned = store_->prune(RetentionPolicy{retention_.keep_snapshots});
  if (!pruned) return;
  out.prune = *pruned;
  std::vector<std::pair<std::string, uint64_t>> segments;  // oldest first
  uint64_t total = 0;
  std::error_code ec;
  for (const std::string& seg : list_segments(data_dir_)) {
    const uint64_t size = fs::file_size(seg, ec);
    segments.push_back({seg, ec ? 0 : size});
    total += ec ? 0 : size;
  }
  for (const auto& [seg, size] : segments) {
    if (total <= retention_.log_cap_bytes) break;
    auto seg_header = read_segment_header(seg);
    if (!seg_header || seg_header->header.segment_index >= out.prune.oldest_needed_segment) break;
    if (fs::remove(seg, ec) && !ec) {
      total -= size;
      ++out.segments_removed;
      out.segment_bytes_removed += size;
    }
  }
  if (out.segments_removed > 0) (void)fsync_path((fs::path(data_dir_) / "log").string());
}

uint64_t folder_bytes(const std::string& dir) {
  uint64_t n = 0;
  std::error_code ec;
  for (const auto& e : fs::recursive_directory_iterator(dir, ec))
    if (e.is_regular_file(ec)) n += e.file_size(ec);
  return n;
}

uint64_t Storage::log_bytes() const { return folder_bytes((fs::path(data_dir_) / "log").string()); }
uint64_t Storage::snapshot_bytes() const {
  return folder_bytes((fs::path(data_dir_) / "snapshots").string());
}

std::string Storage::segment_path_of(uint32_t index) const {
  return (fs::path(data_dir_) / "log" / log::segment_file_name(index)).string();
}

}  // namespace loam::server
