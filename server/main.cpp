// loam-server: host a multiplayer terrain session, and the file tools that go with it.
//   serve            run a session (TCP); SIGINT/SIGTERM stop it cleanly
//   replay LOG...    rebuild the world from a log and print its hash
//   import, export   DEM files in and out (import --pack: a tile pack of any size)
//   pack info|verify what a tile pack holds, and a check of every tile
//   log dump|summary human views of a deformation log
//   snapshot info    what a snapshot holds
//   tokens new       a fresh tokens file (random editor and viewer tokens) for --tokens-file

#include <CLI/CLI.hpp>
#include <asio.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <random>
#include <stdexcept>

#include "app/cli_checks.h"
#include "dem/dem_export.h"
#include "dem/dem_import.h"
#include "dem/pack_import.h"
#include "protocol/base/tile_pack.h"
#include "protocol/hex64.h"
#include "protocol/log/log_file.h"
#include "protocol/log/log_json.h"
#include "protocol/snapshot/snapshot.h"
#include "protocol/wire/access_token.h"
#include "server/access_tokens.h"
#include "server/event_log.h"
#include "server/heap_trimmer.h"
#include "server/replay.h"
#include "server/server.h"
#include "server/storage.h"

namespace {

using namespace loam;

[[noreturn]] void die(const Error& e) { throw std::runtime_error(e.describe()); }

// Exit status of a verification tool (replay, log dump, log summary) that could not read the
// whole log: its output does not describe the session (docs/configuration.md).
constexpr int kExitDamaged = 3;

int serve(const server::ServerConfig& config) {
  // Resident memory follows the caches' budgets: freed heap pages go back to the system.
  const server::HeapTrimmer trimmer;
  const auto kind = gpu::parse_backend_kind(config.backend);
  if (!kind) die(kind.error());
  const auto access = server::load_access_tokens(config);
  if (!access) die(access.error());
  auto opened = server::open_storage(config.data_dir, config.dem_path, config.stamp_limits,
                                     config.stamp_images, config.dem_band, config.terrain);
  if (!opened) die(opened.error());
  opened->terrain.mutable_world().set_base_cache_budget(size_t(config.cache_mb) << 20);
  opened->storage.set_retention({config.keep_snapshots, config.log_retention_bytes});
  // Recovery replays on the CPU; the backend then starts from the recovered world.
  auto backend = gpu::make_stamp_backend(*kind, opened->terrain.world(), &opened->terrain.textures(),
                                         config.stamp_limits);
  if (!backend) die(backend.error());
  server::log_event(
      "backend",
      {{"requested", config.backend}, {"chosen", (*backend)->name()}, {"renderer", (*backend)->renderer()}});
  opened->terrain.set_backend(std::move(*backend));
  const server::RecoveryReport& r = opened->report;
  server::log_event(r.fresh ? "new_session" : "recovered",
                    {{"data_dir", config.data_dir},
                     {"snapshot", r.snapshot_path.empty() ? "none" : r.snapshot_path},
                     {"segments", std::to_string(r.segments)},
                     {"replayed", std::to_string(r.replayed_records)},
                     {"truncated_bytes", std::to_string(r.truncated_bytes)},
                     {"last_seq", std::to_string(r.last_seq)}});
  if (!r.damage.empty()) server::log_event("log_repaired", {{"damage", r.damage}});
  for (const std::string& d : r.older_damage)
    server::log_event("older_segment_damaged",
                      {{"damage", d}, {"effect", "none: a newer snapshot covers it"}});
  for (const std::string& d : r.images_damaged) server::log_event("stamp_image_damaged", {{"why", d}});
  if (r.partial_snapshots_removed > 0)
    server::log_event("partial_snapshots_removed", {{"count", std::to_string(r.partial_snapshots_removed)}});
  if (r.limits_changed) {
    const StampLimits& now = opened->storage.limits();
    server::log_event(
        "limits_recorded",
        {{"recorded_before",
          r.recorded_limits ? "max_radius=" + std::to_string(r.recorded_limits->max_radius_samples) +
                                  " max_steps=" + std::to_string(r.recorded_limits->max_shockwave_steps) +
                                  " max_cells=" + std::to_string(r.recorded_limits->max_shockwave_cells)
                            : std::string("none (log format 1)")},
         {"now", "max_radius=" + std::to_string(now.max_radius_samples) +
                     " max_steps=" + std::to_string(now.max_shockwave_steps) +
                     " max_cells=" + std::to_string(now.max_shockwave_cells)},
         {"effect",
          "logged stamps replayed under the recorded limits; new stamps are checked against the new ones "
          "(a new log segment records them)"}});
  }
  for (const StampTexture* t : opened->terrain.textures().all()) {
    server::log_event("stamp_image", {{"id", hex64(t->id)},
                                      {"size", std::to_string(t->width) + "x" + std::to_string(t->height)}});
  }
  for (const std::string& s : r.skipped) server::log_event("snapshot_skipped", {{"why", s}});
  asio::io_context io;
  server::Server srv(io, config, std::move(*opened));
  if (const Status st = srv.start(); !st.ok()) die(st.error());
  io.run();
  server::log_event("exit", {{"failed", srv.failed() ? "yes" : "no"}});
  return srv.failed() ? 1 : 0;
}

std::vector<std::string> expand_logs(const std::vector<std::string>& args, std::string* data_dir) {
  // A data folder stands for its segments; otherwise the arguments are segment files.
  if (args.size() == 1 && std::filesystem::is_directory(args[0])) {
    *data_dir = args[0];
    return server::list_segments(args[0]);
  }
  if (data_dir->empty() && !args.empty()) {
    // <data>/log/segment-*.loamlog: snapshots live two levels up.
    *data_dir = std::filesystem::path(args[0]).parent_path().parent_path().string();
  }
  return args;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"loam-server: host a Loam terrain session"};
  app.set_version_flag("--version", "loam-server " LOAM_VERSION " (protocol " +
                                        std::to_string(wire::kProtocolMajor) + "." +
                                        std::to_string(wire::kProtocolMinor) + ", log format " +
                                        std::to_string(log::kLogFormatVersion) + ")");
  app.require_subcommand(1);
  app.set_config("--config", "", "Read options from an INI/TOML file (docs/configuration.md)");
  // A misspelt key in the file is an error, not a setting silently left at its default.
  app.allow_config_extras(CLI::config_extras_mode::error);

  server::ServerConfig config;
  auto* serve_cmd = app.add_subcommand("serve", "Run a terrain session over TCP");
  serve_cmd->add_option("--bind", config.bind_address, "Address to listen on")->capture_default_str();
  serve_cmd->add_option("--port", config.port, "TCP port (0: ephemeral)")
      ->capture_default_str()
      ->check(cli::IntRange(0, 65535));
  serve_cmd->add_option("--port-file", config.port_file, "Write the bound port to this file");
  serve_cmd->add_option("--dem", config.dem_path,
                        "Initial terrain DEM: GeoTIFF, PNG, SRTM .hgt, ESRI .asc, VRT or EXR (default: the "
                        "embedded terrain)");
  serve_cmd
      ->add_option("--terrain", config.terrain,
                   "Embedded terrain without --dem: crop (ETOPO5 crop at 2 m) or refined (the crop refined "
                   "to 131 x 98 km at 1 m, generated on demand)")
      ->capture_default_str()
      ->check(CLI::IsMember({"crop", "refined"}));
  serve_cmd
      ->add_option("--cache-mb", config.cache_mb,
                   "Clean tiles kept in memory, MiB: the base's (generated or read again when needed) and "
                   "edited tiles a snapshot holds (read back from it); tiles changed since the last snapshot "
                   "stay besides, up to --snapshot-dirty-mb")
      ->capture_default_str()
      ->check(cli::IntRange(1, int64_t(1) << 20));
  serve_cmd->add_option("--dem-band", config.dem_band, "The DEM's height band, 1-based (0: its only band)")
      ->capture_default_str()
      ->check(cli::IntRange(0, 65535));
  serve_cmd->add_option("--data-dir", config.data_dir, "Log and snapshot folder")->capture_default_str();
  serve_cmd->add_option("--stamp-image", config.stamp_images,
                        "Grayscale image (PNG/TIFF/EXR) to register for texture stamps (repeatable)");
  serve_cmd->add_option("--backend", config.backend, "Stamp backend: auto, gpu or cpu")
      ->capture_default_str();
  serve_cmd->add_option("--tick-hz", config.tick_hz, "Ticks per second")
      ->capture_default_str()
      ->check(cli::IntRange(1, 1000));
  serve_cmd->add_option("--editor-token", config.editor_tokens, "Token (32 hex digits) granting editing");
  serve_cmd->add_option("--tokens-file", config.tokens_file,
                        "File of 'editor HEX' / 'viewer HEX' lines (a mounted secret)");
  serve_cmd->add_option("--viewer-token", config.viewer_tokens,
                        "Token (32 hex digits) granting viewing only");
  // Every number is range-checked here, for the flag and the config-file key alike
  // (app/cli_checks.h); docs/configuration.md lists the same ranges.
  using cli::Bound;
  serve_cmd->add_option("--max-clients", config.max_clients, "Clients in session (through Hello)")
      ->capture_default_str()
      ->check(cli::IntRange(1, 65536));
  serve_cmd
      ->add_option("--max-handshakes", config.max_handshakes,
                   "Connections not yet through Hello, all addresses")
      ->capture_default_str()
      ->check(cli::IntRange(1, 65536));
  serve_cmd
      ->add_option("--max-handshakes-per-address", config.max_handshakes_per_address,
                   "Connections not yet through Hello, from one address")
      ->capture_default_str()
      ->check(cli::IntRange(1, 65536));
  serve_cmd->add_option("--max-frame-bytes", config.max_frame_bytes)
      ->capture_default_str()
      ->check(cli::IntRange(1024, int64_t(1) << 28));
  serve_cmd->add_option("--max-subscriptions", config.max_subscriptions)
      ->capture_default_str()
      ->check(cli::IntRange(1, int64_t(1) << 24));
  serve_cmd
      ->add_option("--max-pending-deforms", config.max_pending_deforms,
                   "Per client: deforms queued and not yet acknowledged")
      ->capture_default_str()
      ->check(cli::IntRange(1, 65536));
  serve_cmd->add_option("--deforms-per-second", config.deforms_per_second, "Rate limit per client")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 1e6, Bound::kOpen));
  serve_cmd->add_option("--deform-burst", config.deform_burst, "Rate limit burst")
      ->capture_default_str()
      ->check(cli::FiniteRange(1, 1e6));
  auto* tls_cert = serve_cmd->add_option("--tls-cert", config.tls_cert_file,
                                         "TLS for client connections: the certificate chain (PEM)");
  auto* tls_key =
      serve_cmd->add_option("--tls-key", config.tls_key_file, "The certificate's private key (PEM)");
  tls_cert->needs(tls_key);
  tls_key->needs(tls_cert);
  serve_cmd
      ->add_option("--metrics-bind", config.metrics_bind,
                   "HOST:PORT for Prometheus metrics over HTTP (GET /metrics); empty: none")
      ->capture_default_str();
  serve_cmd
      ->add_option("--max-stamp-cost", config.max_stamp_cost,
                   "Sample updates one stamp may cost (a shockwave's times its steps)")
      ->capture_default_str()
      ->check(cli::IntRange(1, int64_t(1) << 50));
  serve_cmd
      ->add_option("--stamp-cost-per-second", config.stamp_cost_per_second,
                   "Per client: sample updates a second of stamps")
      ->capture_default_str()
      ->check(cli::IntRange(1, int64_t(1) << 50));
  serve_cmd
      ->add_option("--tick-stamp-cost", config.tick_stamp_cost,
                   "Sample updates applied per tick, all clients (at least one stamp)")
      ->capture_default_str()
      ->check(cli::IntRange(1, int64_t(1) << 50));
  serve_cmd
      ->add_option("--apply-wait-ms", config.apply_wait_ms,
                   "How long a tick waits for its stamps to be applied (off the I/O thread) before going on")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 1000));
  serve_cmd
      ->add_option("--requests-per-second", config.requests_per_second,
                   "Per client: Subscribe, Unsubscribe, Ping, StampImageRequest and StatsRequest")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 1e6, Bound::kOpen));
  serve_cmd->add_option("--request-burst", config.request_burst, "Per client: request bucket capacity")
      ->capture_default_str()
      ->check(cli::FiniteRange(1, 1e6));
  serve_cmd->add_option("--handshake-timeout", config.handshake_timeout_s, "Seconds")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 3600, Bound::kOpen));
  serve_cmd->add_option("--idle-timeout", config.idle_timeout_s, "Seconds (0: none)")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 604800));
  serve_cmd->add_option("--max-queue-bytes", config.max_queue_bytes, "Per-client send queue bound")
      ->capture_default_str()
      ->check(cli::IntRange(65536, int64_t(1) << 40));
  serve_cmd
      ->add_option("--client-budget", config.client_bytes_per_second,
                   "Bytes per second of regions to each client (0: no limit); acks and events go outside it")
      ->capture_default_str()
      ->check(cli::IntRange(0, int64_t(1) << 31));
  serve_cmd
      ->add_option("--max-encodes-per-tick", config.max_encodes_per_tick,
                   "Regions encoded per tick, all clients")
      ->capture_default_str()
      ->check(cli::IntRange(1, 1 << 20));
  serve_cmd
      ->add_option("--region-cache-bytes", config.region_cache_bytes,
                   "Encoded regions kept for other clients")
      ->capture_default_str()
      ->check(cli::IntRange(0, int64_t(1) << 40));
  serve_cmd
      ->add_option("--best-after-uses", config.best_after_uses,
                   "Re-encode a whole tile in the best mode once sent this often (0: never)")
      ->capture_default_str()
      ->check(cli::IntRange(0, 1 << 20));
  serve_cmd
      ->add_option("--history-bytes", config.history_bytes,
                   "Samples kept of recent changes, for delta patches to clients behind")
      ->capture_default_str()
      ->check(cli::IntRange(0, int64_t(1) << 40));
  serve_cmd->add_option("--snapshot-every", config.snapshot_every_stamps, "Stamps between snapshots (0: off)")
      ->capture_default_str()
      ->check(cli::IntRange(0, int64_t(1) << 40));
  serve_cmd
      ->add_option("--snapshot-interval", config.snapshot_interval_s, "Seconds between snapshots (0: off)")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 1e7));
  serve_cmd
      ->add_option("--prefetch-tiles", config.prefetch_tiles,
                   "Base tiles (refined or from a pack) made ahead on a worker thread, for stamps admitted "
                   "and tiles subscribed before the tick reads them (0: off)")
      ->capture_default_str()
      ->check(cli::IntRange(0, 1 << 16));
  uint64_t dirty_mb = config.snapshot_dirty_bytes >> 20;
  serve_cmd
      ->add_option("--snapshot-dirty-mb", dirty_mb,
                   "A snapshot is due when edited tiles no snapshot holds reach this many MiB (they stay in "
                   "memory until one does; 0: no such trigger)")
      ->capture_default_str()
      ->check(cli::IntRange(0, 1 << 20));
  serve_cmd
      ->add_option(
          "--keep-snapshots", config.keep_snapshots,
          "Retention: the newest snapshots kept (older ones and the tiles only they name are removed)")
      ->capture_default_str()
      ->check(cli::IntRange(1, 1000));
  std::string log_retention = "1024";
  serve_cmd
      ->add_option("--log-retention-mb", log_retention,
                   "Retention: log segments older than the oldest kept snapshot are removed while the log "
                   "exceeds this many MiB ('all': keep the whole log, so a replay from the initial terrain "
                   "stays possible)")
      ->capture_default_str()
      ->check(CLI::Validator(
          [](std::string& text) -> std::string {
            if (text == "all") return {};
            std::string probe = text;
            return cli::FiniteRange(0, 1e9)(probe).empty()
                       ? std::string()
                       : "must be a finite number in [0, 1e+09] or 'all', got " + text;
          },
          "[0, 1e+09]|all", "LogRetention"));
  serve_cmd->add_option("--hashes-every", config.hashes_every_ticks, "Ticks between TileHashes (0: never)")
      ->capture_default_str()
      ->check(cli::IntRange(0, 1000000));
  serve_cmd->add_option("--stats-interval", config.stats_interval_s, "Seconds between stats lines (0: off)")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 1e7));
  serve_cmd->add_option("--max-radius", config.stamp_limits.max_radius_samples, "Stamp radius cap in samples")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, kHardMaxRadiusSamples, Bound::kOpen));

  std::vector<std::string> logs;
  std::string replay_data, replay_png, replay_exr, replay_snapshot;
  uint64_t until = std::numeric_limits<uint64_t>::max();
  auto* replay_cmd = app.add_subcommand("replay", "Rebuild the world from a log and print its hash");
  replay_cmd->add_option("logs", logs, "Segment files in order, or a data folder")->required();
  replay_cmd->add_option("--data-dir", replay_data, "Folder holding snapshots/ (for snapshot-based logs)");
  replay_cmd->add_option("--until", until, "Stop after this sequence");
  replay_cmd->add_option("--export-png", replay_png, "Write the result as 16-bit PNG");
  replay_cmd->add_option("--export-exr", replay_exr, "Write the result as float EXR");
  replay_cmd->add_option("--snapshot-out", replay_snapshot,
                         "Write the result as a snapshot under this folder");
  std::string replay_backend = "cpu";
  std::vector<std::string> replay_images;
  replay_cmd->add_option("--stamp-image", replay_images,
                         "Texture-stamp image the session registered (repeatable)");
  replay_cmd->add_option("--backend", replay_backend, "Stamp backend: auto, gpu or cpu")
      ->capture_default_str();
  bool allow_damaged = false;
  replay_cmd->add_flag("--allow-damaged", allow_damaged,
                       "Replay the records before a damaged tail and exit 0 (default: exit 3, no hash)");

  std::string dem_in, out_path;
  auto* import_cmd = app.add_subcommand("import", "Import a DEM and report its quantization");
  import_cmd->add_option("dem", dem_in, "DEM file: GeoTIFF/COG, PNG, SRTM .hgt, ESRI .asc, VRT or EXR")
      ->required();
  std::optional<int> import_band;
  std::optional<double> import_mps, import_vscale, import_voffset;
  import_cmd->add_option("--band", import_band, "The height band, 1-based (required for multi-band images)")
      ->check(cli::IntRange(1, 65535));
  import_cmd->add_option("--meters-per-sample", import_mps, "Horizontal spacing (overrides sidecar and CRS)")
      ->check(cli::FiniteRange(0, 1e7, cli::Bound::kOpen));
  import_cmd->add_option("--vertical-scale", import_vscale, "Metres per source unit")
      ->check(cli::FiniteRange(0, 1e6, cli::Bound::kOpen));
  import_cmd->add_option("--vertical-offset", import_voffset, "Metres at source value 0")
      ->check(cli::FiniteRange(-1e7, 1e7));
  import_cmd->add_option("--png", out_path, "Also write the imported world as PNG + sidecar");
  std::string pack_out;
  import_cmd->add_option("--pack", pack_out,
                         "Write the world as a tile pack (.loampack) for serve --dem, reading the DEM in "
                         "strips: any size up to 2^17 samples a side, in bounded memory");
  auto* pack_cmd = app.add_subcommand("pack", "Tile packs: what one holds, and a check of every tile");
  pack_cmd->require_subcommand(1);
  std::string pack_path;
  auto* pack_info_cmd = pack_cmd->add_subcommand("info", "Parameters, identity, tiles and bytes");
  auto* pack_verify_cmd = pack_cmd->add_subcommand("verify", "Decode every tile and check its hash");
  for (auto* c : {pack_info_cmd, pack_verify_cmd})
    c->add_option("pack", pack_path, "A .loampack file")->required();
  auto* export_cmd = app.add_subcommand("export", "Export a data folder's current world");
  std::string export_dir;
  export_cmd->add_option("data_dir", export_dir, "Data folder")->required();
  export_cmd->add_option("output", out_path, "Output .png or .exr")->required();

  auto* log_cmd = app.add_subcommand("log", "Human views of a deformation log");
  log_cmd->require_subcommand(1);
  auto* dump_cmd = log_cmd->add_subcommand("dump", "Print header and records as JSON lines");
  dump_cmd->add_option("logs", logs, "Segment files or a data folder")->required();
  auto* summary_cmd = log_cmd->add_subcommand("summary", "Records, sequence range, kinds, time");
  summary_cmd->add_option("logs", logs, "Segment files or a data folder")->required();
  bool summary_json = false;
  summary_cmd->add_flag("--json", summary_json, "Print JSON instead of text");
  for (auto* c : {dump_cmd, summary_cmd}) {
    c->add_flag("--allow-damaged", allow_damaged, "Exit 0 even when a segment is damaged (default: exit 3)");
  }
  std::string repair_segment;
  uint64_t repair_offset = 0;
  auto* repair_cmd = log_cmd->add_subcommand(
      "repair", "Cut the last segment at its damage (drops the damaged record and everything after it)");
  repair_cmd->add_option("segment", repair_segment, "Segment file, or a data folder (its last segment)")
      ->required();
  repair_cmd
      ->add_option("--at", repair_offset,
                   "The damage's byte offset, as `log dump` reports it (required: confirms what is dropped)")
      ->required();

  auto* snap_cmd = app.add_subcommand("snapshot", "Snapshot tools");
  snap_cmd->require_subcommand(1);
  std::string snap_path;
  auto* info_cmd = snap_cmd->add_subcommand("info", "Print what a snapshot holds (verifying it)");
  info_cmd->add_option("path", snap_path, "Snapshot folder")->required();

  auto* tokens_cmd = app.add_subcommand("tokens", "Access tokens");
  tokens_cmd->require_subcommand(1);
  int new_editors = 1, new_viewers = 1;
  std::string tokens_out;
  bool tokens_force = false;
  auto* tokens_new_cmd = tokens_cmd->add_subcommand(
      "new",
      "Write a tokens file with fresh random tokens (for --tokens-file): to FILE (mode 0600), or stdout");
  auto* tokens_file_opt =
      tokens_new_cmd->add_option("file", tokens_out, "File to create with mode 0600 (default: stdout)");
  tokens_new_cmd->add_flag("--force", tokens_force, "Replace FILE if it exists")->needs(tokens_file_opt);
  tokens_new_cmd->add_option("--editors", new_editors, "Editor tokens")
      ->capture_default_str()
      ->check(cli::IntRange(0, 1000));
  tokens_new_cmd->add_option("--viewers", new_viewers, "Viewer tokens")
      ->capture_default_str()
      ->check(cli::IntRange(0, 1000));

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  try {
    if (*serve_cmd) {
      config.snapshot_dirty_bytes = dirty_mb << 20;
      if (log_retention == "all") {
        config.log_retention_bytes = UINT64_MAX;
      } else {
        config.log_retention_bytes = uint64_t(std::strtod(log_retention.c_str(), nullptr) * double(1 << 20));
      }
      return serve(config);
    }
    if (*tokens_new_cmd) {
      if (new_editors + new_viewers == 0)
        die(make_error(ErrorCode::kInvalidArgument, "tokens new", "no tokens asked for"));
      // 128 bits each from the kernel's generator (std::random_device reads getrandom here).
      std::random_device rd;
      auto fresh = [&] {
        wire::AccessToken t;
        for (size_t i = 0; i < t.size(); i += 4) {
          const uint32_t v = rd();
          for (size_t b = 0; b < 4; ++b) t[i + b] = uint8_t(v >> (8 * b));
        }
        return wire::format_access_token(t);
      };
      std::string text =
          "# loam-server tokens file (--tokens-file): an editor token lets a client deform,\n"
          "# a viewer token only watch. Keep this file secret (chmod 600).\n";
      for (int i = 0; i < new_editors; ++i) text += "editor " + fresh() + "\n";
      for (int i = 0; i < new_viewers; ++i) text += "viewer " + fresh() + "\n";
      if (tokens_out.empty()) {
        std::fputs(text.c_str(), stdout);
      } else if (const Status st = server::write_private_file(tokens_out, text, tokens_force); !st.ok()) {
        die(st.error());
      }
      return 0;
    }
    if (*replay_cmd) {
      const auto segs = expand_logs(logs, &replay_data);
      const auto kind = gpu::parse_backend_kind(replay_backend);
      if (!kind) die(kind.error());
      auto r = server::replay_log(segs, replay_data, until, *kind, replay_images, allow_damaged);
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
      if (!replay_png.empty() && !export_png16(r->world, all, replay_png).ok())
        throw std::runtime_error("PNG export failed");
      if (!replay_exr.empty() && !export_exr(r->world, all, replay_exr).ok())
        throw std::runtime_error("EXR export failed");
      if (!replay_snapshot.empty()) {
        auto p = write_snapshot(replay_snapshot, r->world, r->last_seq, 0, TextureRegistry{});
        if (!p) die(p.error());
        std::printf("snapshot %s\n", p->c_str());
      }
      return 0;
    }
    if (*import_cmd) {
      DemScaleOptions scale;
      scale.band = import_band;
      scale.meters_per_sample = import_mps;
      scale.vertical_scale = import_vscale;
      scale.vertical_offset = import_voffset;
      if (!pack_out.empty()) {
        if (!out_path.empty()) throw std::runtime_error("--png and --pack are separate imports: choose one");
        if (pack_out.size() < 9 || pack_out.substr(pack_out.size() - 9) != kPackExtension)
          throw std::runtime_error("--pack: the file name must end in .loampack");
        auto r = import_dem_to_pack(dem_in, pack_out, scale);
        if (!r) die(r.error());
        const PackSummary& p = r->pack;
        const double mib = double(r->import.width) * double(r->import.height) * 2.0 / double(1 << 20);
        std::printf(
            "%spack              %s\n"
            "identity          %016llx\n"
            "tiles             %llu (every mip), %.1f MiB (%.2f bytes a sample at mip 0)\n"
            "time              scan %.1f s, write %.1f s (%.0f MiB/s of 16-bit samples)\n",
            r->import.summary().c_str(), p.path.c_str(), (unsigned long long)p.identity,
            (unsigned long long)p.tiles, double(p.file_bytes) / double(1 << 20),
            double(p.file_bytes) / (double(r->import.width) * double(r->import.height)), r->scan_seconds,
            r->write_seconds, mib / std::max(1e-9, r->scan_seconds + r->write_seconds));
        return 0;
      }
      auto dem = read_dem_file(dem_in, scale);
      if (!dem) die(dem.error());
      auto w = import_dem(*dem);
      if (!w) die(w.error());
      std::printf("%sworld hash        %s\n", w->report.summary().c_str(),
                  hex64(w->world.world_hash()).c_str());
      if (!out_path.empty()) {
        const Status st = export_png16(w->world, w->world.params().sample_rect(), out_path);
        if (!st.ok()) die(st.error());
      }
      return 0;
    }
    if (*pack_info_cmd || *pack_verify_cmd) {
      auto pack = open_tile_pack(pack_path);
      if (!pack) die(pack.error());
      const PackSummary& p = (*pack)->summary();
      std::printf(
          "pack              %s\n"
          "identity          %016llx\n"
          "world             %d x %d tiles at %.6g m/sample, %.6g m/unit, offset %.6f m\n"
          "tiles             %llu over %d mips, %llu bytes\n",
          p.path.c_str(), (unsigned long long)p.identity, p.params.tiles_x, p.params.tiles_y,
          p.params.meters_per_sample, p.params.meters_per_unit, p.params.height_offset,
          (unsigned long long)p.tiles, p.params.mip_count(), (unsigned long long)p.file_bytes);
      if (*pack_verify_cmd) {
        const Status st = (*pack)->verify();
        if (!st.ok()) {
          std::fprintf(stderr, "damaged: %s\n", st.error().describe().c_str());
          return kExitDamaged;
        }
        std::printf("verified          every tile decodes to its hash\n");
      }
      return 0;
    }
    if (*export_cmd) {
      auto opened = server::read_session(export_dir);
      if (!opened) die(opened.error());
      const World& w = opened->terrain.world();
      const bool exr = out_path.size() > 4 && out_path.substr(out_path.size() - 4) == ".exr";
      const Status st = exr ? export_exr(w, w.params().sample_rect(), out_path)
                            : export_png16(w, w.params().sample_rect(), out_path);
      if (!st.ok()) die(st.error());
      std::printf("wrote %s (sequence %llu, world hash %s)\n", out_path.c_str(),
                  (unsigned long long)opened->terrain.last_seq(), hex64(w.world_hash()).c_str());
      return 0;
    }
    if (*dump_cmd || *summary_cmd) {
      std::string dir;
      const auto segs = expand_logs(logs, &dir);
      std::vector<log::SegmentScan> scans;
      std::vector<std::string> damaged;
      for (const std::string& s : segs) {
        auto scan = log::read_segment(s);
        if (!scan) {
          // An unreadable segment: the others are still shown, and the exit says so.
          damaged.push_back(scan.error().describe());
          continue;
        }
        if (scan->tail_error) damaged.push_back(s + ": " + scan->tail_error->describe());
        scans.push_back(std::move(*scan));
      }
      if (*dump_cmd) {
        for (const auto& s : scans) std::fputs(log::dump_jsonl(s).c_str(), stdout);
      } else {
        const auto sum = log::summarize(scans);
        std::fputs((summary_json ? log::summary_to_json(sum) : log::summary_to_text(sum)).c_str(), stdout);
      }
      for (const std::string& d : damaged) std::fprintf(stderr, "loam-server: damaged: %s\n", d.c_str());
      if (!damaged.empty() && !allow_damaged) return kExitDamaged;
      return 0;
    }
    if (*repair_cmd) {
      std::string dir;
      auto segs = expand_logs({repair_segment}, &dir);
      if (segs.empty()) die(make_error(ErrorCode::kNotFound, repair_segment, "no log segments"));
      const std::string& seg = segs.back();
      auto scan = log::read_segment(seg);
      if (!scan) die(scan.error());
      if (!scan->tail_error) {
        std::printf("%s: clean, nothing to repair\n", seg.c_str());
        return 0;
      }
      if (scan->damage_offset != repair_offset) {
        die(make_error(ErrorCode::kInvalidArgument, "--at",
                       seg + " is damaged at byte offset " + std::to_string(scan->damage_offset) + ", not " +
                           std::to_string(repair_offset) + " (" + scan->tail_error->describe() + ")"));
      }
      auto bytes = log::read_file(seg);
      if (!bytes) die(bytes.error());
      const uint64_t dropped = bytes->size() - scan->good_bytes;
      const auto cut = log::truncate_segment(seg, scan->good_bytes);
      if (!cut.ok()) die(cut.error());
      std::printf(
          "%s: cut at byte offset %zu: dropped %llu bytes (at most %llu records) after sequence %llu (%s)\n",
          seg.c_str(), scan->good_bytes, (unsigned long long)dropped,
          (unsigned long long)((dropped + log::kRecordOverheadBytes + log::kStampRecordBodyBytes - 1) /
                               (log::kRecordOverheadBytes + log::kStampRecordBodyBytes)),
          (unsigned long long)scan->last_seq(), scan->tail_error->describe().c_str());
      return 0;
    }
    if (*info_cmd) {
      // The snapshot's base: one this program generates (a fill, the refined default), else the
      // session's tile pack that the log beside it names.
      std::shared_ptr<const TileBase> base;
      if (auto manifest = read_snapshot_manifest(snap_path)) {
        if (auto known = server::known_base_of_snapshot(snap_path, manifest->base_identity)) base = *known;
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
  } catch (const std::exception& e) {
    std::fprintf(stderr, "loam-server: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
