#include "server/replay.h"

#include "dem/stamp_texture_io.h"
#include "gpu/stamp_backend.h"
#include "protocol/log/log_file.h"
#include "server/terrain_source.h"
#include "server/terrain_state.h"

namespace loam::server {

Result<ReplayResult> replay_log(const std::vector<std::string>& segments, const std::string& data_dir,
                                uint64_t until_seq, gpu::BackendKind backend,
                                const std::vector<std::string>& stamp_images) {
  if (segments.empty()) return make_error(ErrorCode::kInvalidArgument, "log", "no log segments given");
  auto scans = log::read_log(segments);
  if (!scans) return scans.error();
  const log::SegmentHeader& first = scans->front().header.header;
  if (first.base_seq != 0) {
    return make_error(ErrorCode::kInvalidArgument, segments.front(),
                      "replay starts at segment 0 (this segment continues from sequence " +
                          std::to_string(first.base_seq) + ")");
  }
  auto world = load_described_terrain(first.initial, data_dir);
  if (!world) return world.error();
  TerrainState terrain(std::move(*world), 0);
  for (const std::string& f : stamp_images) {
    auto id = register_stamp_texture_file(terrain.textures(), f);
    if (!id) return id.error();
  }
  if (backend != gpu::BackendKind::kCpu) {
    auto made = gpu::make_stamp_backend(backend, terrain.world(), &terrain.textures(), terrain.limits());
    if (!made) return made.error();
    terrain.set_backend(std::move(*made));
  }
  ReplayResult out{World(first.world, 0), 0, 0, 0, {}};
  for (const log::SegmentScan& scan : *scans) {
    if (scan.tail != log::TailState::kClean && scan.tail_error) out.tail_damage = scan.tail_error->describe();
    for (const log::LogRecord& r : scan.records) {
      if (r.global_seq > until_seq) break;
      if (r.global_seq != terrain.last_seq() + 1) {
        return make_error(ErrorCode::kCorrupt, "log",
                          "sequence gap: expected " + std::to_string(terrain.last_seq() + 1) + ", found " +
                              std::to_string(r.global_seq));
      }
      if (!terrain.apply(r.stamp, r.global_seq, r.client_id)) ++out.failed_stamps;
      ++out.records;
    }
  }
  out.last_seq = terrain.last_seq();
  out.world = std::move(terrain.mutable_world());
  return out;
}

}  // namespace loam::server
