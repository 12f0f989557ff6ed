#include "server/replay.h"

#include <filesystem>
#include <optional>

#include "dem/stamp_texture_io.h"
#include "gpu/stamp_backend.h"
#include "protocol/log/log_file.h"
#include "protocol/snapshot/snapshot.h"
#include "server/stamp_image_store.h"
#include "server/terrain_source.h"
#include "server/terrain_state.h"

namespace loam::server {

Result<ReplayResult> replay_log(const std::vector<std::string>& segments, const std::string& data_dir,
                                uint64_t until_seq, gpu::BackendKind backend,
                                const std::vector<std::string>& stamp_images, bool allow_damaged) {
  if (segments.empty()) return make_error(ErrorCode::kInvalidArgument, "log", "no log segments given");
  // With allow_damaged, the log ends at the first damaged segment: its records before the
  // damage replay, and the segments after it (which cannot chain to it) are left out.
  std::vector<std::string> readable = segments;
  std::string left_out;
  if (allow_damaged) {
    for (size_t i = 0; i < segments.size(); ++i) {
      auto scan = log::read_segment(segments[i]);
      const bool damaged = !scan || scan->tail != log::TailState::kClean;
      if (!damaged) continue;
      readable.resize(scan ? i + 1 : i);
      if (segments.size() > readable.size())
        left_out = "; " + std::to_string(segments.size() - readable.size()) + " segment(s) after it left out";
      if (!scan) left_out = scan.error().describe() + left_out;
      break;
    }
    if (readable.empty()) return make_error(ErrorCode::kCorrupt, segments.front(), left_out);
  }
  auto scans = log::read_log(readable);
  if (!scans) return scans.error();
  const log::SegmentHeader& first = scans->front().header.header;
  // A log whose first segments were pruned (retention) starts at the snapshot its first
  // remaining segment continues, when the data folder still holds it.
  std::optional<LoadedSnapshot> start;
  if (first.base_seq != 0) {
    const std::string snap_path =
        data_dir.empty()
            ? std::string()
            : (std::filesystem::path(data_dir) / "snapshots" / snapshot_dir_name(first.base_snapshot_id))
                  .string();
    std::error_code ec;
    if (snap_path.empty() || !std::filesystem::exists(snap_path, ec)) {
      return make_error(
          ErrorCode::kInvalidArgument, segments.front(),
          "replay starts at segment 0 or at a kept snapshot (this segment continues from sequence " +
              std::to_string(first.base_seq) + ", and its snapshot is not in the data folder)");
    }
    auto manifest = read_snapshot_manifest(snap_path);
    if (!manifest) return manifest.error();
    auto base = resolve_base(manifest->base_identity, first.initial, data_dir);
    if (!base) return base.error();
    auto loaded = read_snapshot(snap_path, *base);
    if (!loaded) return loaded.error();
    if (loaded->manifest.last_seq != first.base_seq)
      return make_error(ErrorCode::kCorrupt, snap_path, "the snapshot is not at the segment's base sequence");
    start.emplace(std::move(*loaded));
  }
  for (size_t i = 0; i < scans->size(); ++i) {
    const log::SegmentScan& scan = (*scans)[i];
    if (scan.tail == log::TailState::kClean || !scan.tail_error || allow_damaged) continue;
    return make_error(ErrorCode::kCorrupt, segments[i],
                      std::string("damaged (") + log::to_string(scan.tail) + ") at byte offset " +
                          std::to_string(scan.damage_offset) + ": " + scan.tail_error->describe() +
                          "; the records after it cannot be read, so the hash would not be the session's "
                          "(--allow-damaged replays what can be read)");
  }
  auto world = start ? Result<World>(std::move(start->world))
                     : load_described_terrain(first.initial, first.world, data_dir);
  if (!world) return world.error();
  TerrainState terrain(std::move(*world), start ? first.base_seq : 0);
  if (start) {
    for (const StampTexture& t : start->textures) (void)terrain.textures().add(t.width, t.height, t.samples);
  }
  if (!data_dir.empty()) {
    const LoadedImages stored = load_stamp_images(data_dir, terrain.textures());
    (void)stored;  // a damaged image fails the record that needs it, by name
  }
  for (const std::string& f : stamp_images) {
    auto id = register_stamp_texture_file(terrain.textures(), f);
    if (!id) return id.error();
  }
  if (backend != gpu::BackendKind::kCpu) {
    // The widest limits: each segment's own are checked by TerrainState::apply.
    const StampLimits widest{kHardMaxRadiusSamples, kHardMaxShockwaveSteps, kHardMaxShockwaveCells};
    auto made = gpu::make_stamp_backend(backend, terrain.world(), &terrain.textures(), widest);
    if (!made) return made.error();
    terrain.set_backend(std::move(*made));
  }
  ReplayResult out{World(first.world, 0), 0, 0, {}};
  for (size_t i = 0; i < scans->size(); ++i) {
    const log::SegmentScan& scan = (*scans)[i];
    if (scan.tail != log::TailState::kClean && scan.tail_error)
      out.tail_damage = segments[i] + ": " + scan.tail_error->describe() + left_out;
    else if (!left_out.empty() && i + 1 == scans->size())
      out.tail_damage = left_out;
    // Each segment's records mean what they meant under the limits it recorded (version 1
    // segments recorded none: the defaults).
    terrain.set_limits(scan.header.header.has_limits ? scan.header.header.limits : StampLimits{});
    for (const log::LogRecord& r : scan.records) {
      if (r.global_seq > until_seq) break;
      if (r.global_seq != terrain.last_seq() + 1) {
        return make_error(ErrorCode::kCorrupt, "log",
                          "sequence gap: expected " + std::to_string(terrain.last_seq() + 1) + ", found " +
                              std::to_string(r.global_seq));
      }
      if (auto applied = terrain.apply(r.stamp, r.global_seq, r.client_id); !applied) {
        return make_error(applied.error().code, "log",
                          "record " + std::to_string(r.global_seq) + " (" + to_string(r.stamp.kind) +
                              ", client " + std::to_string(r.client_id) + ", tick " + std::to_string(r.tick) +
                              ") of " + segments[i] + " fails to apply: " + applied.error().describe());
      }
      ++out.records;
    }
  }
  out.last_seq = terrain.last_seq();
  out.world = std::move(terrain.mutable_world());
  return out;
}

}  // namespace loam::server
