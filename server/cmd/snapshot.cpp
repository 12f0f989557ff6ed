// loam-server snapshot info PATH: what a snapshot holds, verifying every tile as it reads it.
#include "protocol/snapshot/snapshot.h"

#include <cstdio>
#include <memory>

#include "protocol/hex64.h"
#include "server/cmd/command.h"
#include "server/storage.h"

namespace loam::server::cmd {

namespace {

int info(const std::string& snap_path) {
  // The snapshot's base: one this program generates (a fill, the refined default), else the
  // session's tile pack that the log beside it names.
  std::shared_ptr<const TileBase> base;
  if (auto manifest = read_snapshot_manifest(snap_path)) {
    if (auto known = known_base_of_snapshot(snap_path, manifest->base_identity)) base = *known;
  }
  auto snap = read_snapshot(snap_path, base);
  if (!snap) die(snap.error());
  const auto& m = snap->manifest;
  std::printf(
      "snapshot %llu (after sequence %llu), verified\nworld hash %s\ntiles %zu coarse, %zu detail, %llu "
      "bytes\n"
      "world %d x %d tiles, %.3f m/sample, next log segment %u\n",
      (unsigned long long)m.snapshot_id, (unsigned long long)m.last_seq, hex64(m.world_hash).c_str(),
      m.coarse_tiles, m.detail_tiles, (unsigned long long)m.tiles_bytes, m.world.tiles_x, m.world.tiles_y,
      m.world.meters_per_sample, m.next_segment_index);
  return 0;
}

}  // namespace

Command add_snapshot(CLI::App& app) {
  auto path = std::make_shared<std::string>();
  auto* snap_cmd = app.add_subcommand("snapshot", "Snapshot tools");
  snap_cmd->require_subcommand(1);
  auto* info_cmd = snap_cmd->add_subcommand("info", "Print what a snapshot holds (verifying it)");
  info_cmd->add_option("path", *path, "Snapshot folder")->required();
  return {snap_cmd, [path, info_cmd] { return *info_cmd ? info(*path) : 0; }};
}

}  // namespace loam::server::cmd
