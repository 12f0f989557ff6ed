// loam-server replay LOG...: rebuild the world from a log (and the snapshot it starts from)
// and print its hash; optionally export it as an image or a snapshot.
#include "server/replay.h"

#include <cstdio>
#include <limits>
#include <memory>
#include <stdexcept>

#include "dem/dem_export.h"
#include "protocol/hex64.h"
#include "protocol/snapshot/snapshot.h"
#include "server/cmd/command.h"

namespace loam::server::cmd {

namespace {

struct ReplayOptions {
  std::vector<std::string> logs;
  std::string data_dir, png, exr, snapshot;
  uint64_t until = std::numeric_limits<uint64_t>::max();
  std::string backend = "cpu";
  std::vector<std::string> images;
  bool allow_damaged = false;
};

int replay(ReplayOptions& o) {
  const auto segs = expand_logs(o.logs, &o.data_dir);
  const auto kind = gpu::parse_backend_kind(o.backend);
  if (!kind) die(kind.error());
  auto r = replay_log(segs, o.data_dir, o.until, *kind, o.images, o.allow_damaged);
  if (!r) {
    std::fprintf(stderr, "loam-server: error: %s\n", r.error().describe().c_str());
    return r.error().code == ErrorCode::kCorrupt ? kExitDamaged : 1;
  }
  std::printf("records %llu, last sequence %llu\n", (unsigned long long)r->records,
              (unsigned long long)r->last_seq);
  if (!r->tail_damage.empty())
    std::printf("ignored damaged tail (--allow-damaged): %s\n", r->tail_damage.c_str());
  std::printf("world hash %s\n", hex64(r->world.world_hash()).c_str());
  const RectI all = r->world.params().sample_rect();
  if (!o.png.empty() && !export_png16(r->world, all, o.png).ok())
    throw std::runtime_error("PNG export failed");
  if (!o.exr.empty() && !export_exr(r->world, all, o.exr).ok()) throw std::runtime_error("EXR export failed");
  if (!o.snapshot.empty()) {
    auto p = write_snapshot(o.snapshot, r->world, r->last_seq, 0, TextureRegistry{});
    if (!p) die(p.error());
    std::printf("snapshot %s\n", p->c_str());
  }
  return 0;
}

}  // namespace

Command add_replay(CLI::App& app) {
  auto o = std::make_shared<ReplayOptions>();
  auto* replay_cmd = app.add_subcommand("replay", "Rebuild the world from a log and print its hash");
  replay_cmd->add_option("logs", o->logs, "Segment files in order, or a data folder")->required();
  replay_cmd->add_option("--data-dir", o->data_dir, "Folder holding snapshots/ (for snapshot-based logs)");
  replay_cmd->add_option("--until", o->until, "Stop after this sequence");
  replay_cmd->add_option("--export-png", o->png, "Write the result as 16-bit PNG");
  replay_cmd->add_option("--export-exr", o->exr, "Write the result as float EXR");
  replay_cmd->add_option("--snapshot-out", o->snapshot, "Write the result as a snapshot under this folder");
  replay_cmd->add_option("--stamp-image", o->images,
                         "Texture-stamp image the session registered (repeatable)");
  replay_cmd->add_option("--backend", o->backend, "Stamp backend: auto, gpu or cpu")->capture_default_str();
  replay_cmd->add_flag("--allow-damaged", o->allow_damaged,
                       "Replay the records before a damaged tail and exit 0 (default: exit 3, no hash)");
  return {replay_cmd, [o] { return replay(*o); }};
}

}  // namespace loam::server::cmd
