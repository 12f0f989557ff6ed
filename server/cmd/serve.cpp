// loam-server serve: run a terrain session over TCP (server/server.h) until SIGINT/SIGTERM.
// Its options set ServerConfig (server_config.h); docs/configuration.md lists each with its range.
#include <asio.hpp>
#include <cstdlib>
#include <memory>

#include "app/cli_checks.h"
#include "protocol/hex64.h"
#include "server/access_tokens.h"
#include "server/cmd/command.h"
#include "server/event_log.h"
#include "server/heap_trimmer.h"
#include "server/server.h"
#include "server/storage.h"

namespace loam::server::cmd {

namespace {

int serve(const ServerConfig& config) {
  // Resident memory follows the caches' budgets: freed heap pages go back to the system.
  const HeapTrimmer trimmer;
  const auto kind = gpu::parse_backend_kind(config.backend);
  if (!kind) die(kind.error());
  const auto access = load_access_tokens(config);
  if (!access) die(access.error());
  auto opened = open_storage(config.data_dir, config.dem_path, config.stamp_limits, config.stamp_images,
                             {config.dem_band, config.nodata_fill, config.project}, config.terrain);
  if (!opened) die(opened.error());
  opened->terrain.mutable_world().set_base_cache_budget(size_t(config.cache_mb) << 20);
  opened->storage.set_retention({config.keep_snapshots, config.log_retention_bytes});
  // Recovery replays on the CPU; the backend then starts from the recovered world.
  auto backend = gpu::make_stamp_backend(*kind, opened->terrain.world(), &opened->terrain.textures(),
                                         config.stamp_limits);
  if (!backend) die(backend.error());
  log_event(
      "backend",
      {{"requested", config.backend}, {"chosen", (*backend)->name()}, {"renderer", (*backend)->renderer()}});
  opened->terrain.set_backend(std::move(*backend));
  const RecoveryReport& r = opened->report;
  log_event(r.fresh ? "new_session" : "recovered",
            {{"data_dir", config.data_dir},
             {"snapshot", r.snapshot_path.empty() ? "none" : r.snapshot_path},
             {"segments", std::to_string(r.segments)},
             {"replayed", std::to_string(r.replayed_records)},
             {"truncated_bytes", std::to_string(r.truncated_bytes)},
             {"last_seq", std::to_string(r.last_seq)}});
  if (!r.damage.empty()) log_event("log_repaired", {{"damage", r.damage}});
  for (const std::string& d : r.older_damage)
    log_event("older_segment_damaged", {{"damage", d}, {"effect", "none: a newer snapshot covers it"}});
  for (const std::string& d : r.images_damaged) log_event("stamp_image_damaged", {{"why", d}});
  if (r.partial_snapshots_removed > 0)
    log_event("partial_snapshots_removed", {{"count", std::to_string(r.partial_snapshots_removed)}});
  if (r.limits_changed) {
    const StampLimits& now = opened->storage.limits();
    log_event(
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
    log_event("stamp_image",
              {{"id", hex64(t->id)}, {"size", std::to_string(t->width) + "x" + std::to_string(t->height)}});
  }
  for (const std::string& s : r.skipped) log_event("snapshot_skipped", {{"why", s}});
  asio::io_context io;
  Server srv(io, config, std::move(*opened));
  if (const Status st = srv.start(); !st.ok()) die(st.error());
  io.run();
  log_event("exit", {{"failed", srv.failed() ? "yes" : "no"}});
  return srv.failed() ? 1 : 0;
}

struct ServeOptions {
  ServerConfig config;
  uint64_t dirty_mb = 0;
  std::string log_retention = "1024";
};

// Every number is range-checked here, for the flag and the config-file key alike
// (app/cli_checks.h); docs/configuration.md lists the same ranges.
void add_serve_options(CLI::App* serve_cmd, ServeOptions* o) {
  ServerConfig& c = o->config;
  serve_cmd->add_option("--bind", c.bind_address, "Address to listen on")->capture_default_str();
  serve_cmd->add_option("--port", c.port, "TCP port (0: ephemeral)")
      ->capture_default_str()
      ->check(cli::IntRange(0, 65535));
  serve_cmd->add_option("--port-file", c.port_file, "Write the bound port to this file");
  serve_cmd->add_option("--dem", c.dem_path,
                        "Initial terrain DEM: GeoTIFF, PNG, SRTM .hgt, ESRI .asc, VRT or EXR (default: the "
                        "embedded terrain)");
  serve_cmd
      ->add_option("--terrain", c.terrain,
                   "Embedded terrain without --dem: crop (ETOPO5 crop at 2 m) or refined (the crop refined "
                   "to 131 x 98 km at 1 m, generated on demand)")
      ->capture_default_str()
      ->check(CLI::IsMember({"crop", "refined"}));
  serve_cmd
      ->add_option("--cache-mb", c.cache_mb,
                   "Clean tiles kept in memory, MiB: the base's (generated or read again when needed) and "
                   "edited tiles a snapshot holds (read back from it); tiles changed since the last snapshot "
                   "stay besides, up to --snapshot-dirty-mb")
      ->capture_default_str()
      ->check(cli::IntRange(1, int64_t(1) << 20));
  serve_cmd->add_option("--dem-band", c.dem_band, "The DEM's height band, 1-based (0: its only band)")
      ->capture_default_str()
      ->check(cli::IntRange(0, 65535));
  serve_cmd
      ->add_option_function<std::string>(
          "--nodata-fill",
          [&c](const std::string& v) {
            auto fill = NodataFill::parse(v);
            if (!fill) throw CLI::ValidationError("--nodata-fill", fill.error().message);
            c.nodata_fill = *fill;
          },
          "What the DEM's NoData samples become: interpolate (from the data within 64 samples), min (the "
          "data minimum) or value:H (H metres); the log records it")
      ->default_str("interpolate");
  serve_cmd
      ->add_option_function<std::string>(
          "--project",
          [&c](const std::string& v) {
            auto p = parse_local_projection(v);
            if (!p) throw CLI::ValidationError("--project", p.error().message);
            c.project = *p;
          },
          "Warp a geographic DEM (degrees) to square metres first: aeqd (azimuthal equidistant at its "
          "centre) or utm (its centre's zone); none takes the centre's mean spacing. The log records it")
      ->default_str("none");
  serve_cmd->add_option("--data-dir", c.data_dir, "Log and snapshot folder")->capture_default_str();
  serve_cmd->add_option("--stamp-image", c.stamp_images,
                        "Grayscale image (PNG/TIFF/EXR) to register for texture stamps (repeatable)");
  serve_cmd->add_option("--backend", c.backend, "Stamp backend: auto, gpu or cpu")->capture_default_str();
  serve_cmd->add_option("--tick-hz", c.tick_hz, "Ticks per second")
      ->capture_default_str()
      ->check(cli::IntRange(1, 1000));
  serve_cmd->add_option("--editor-token", c.editor_tokens, "Token (32 hex digits) granting editing");
  serve_cmd->add_option("--tokens-file", c.tokens_file,
                        "File of 'editor HEX' / 'viewer HEX' lines (a mounted secret)");
  serve_cmd->add_option("--viewer-token", c.viewer_tokens, "Token (32 hex digits) granting viewing only");
  using cli::Bound;
  serve_cmd->add_option("--max-clients", c.max_clients, "Clients in session (through Hello)")
      ->capture_default_str()
      ->check(cli::IntRange(1, 65536));
  serve_cmd
      ->add_option("--max-handshakes", c.max_handshakes, "Connections not yet through Hello, all addresses")
      ->capture_default_str()
      ->check(cli::IntRange(1, 65536));
  serve_cmd
      ->add_option("--max-handshakes-per-address", c.max_handshakes_per_address,
                   "Connections not yet through Hello, from one address")
      ->capture_default_str()
      ->check(cli::IntRange(1, 65536));
  serve_cmd->add_option("--max-frame-bytes", c.max_frame_bytes)
      ->capture_default_str()
      ->check(cli::IntRange(1024, int64_t(1) << 28));
  serve_cmd->add_option("--max-subscriptions", c.max_subscriptions)
      ->capture_default_str()
      ->check(cli::IntRange(1, int64_t(1) << 24));
  serve_cmd
      ->add_option("--max-pending-deforms", c.max_pending_deforms,
                   "Per client: deforms queued and not yet acknowledged")
      ->capture_default_str()
      ->check(cli::IntRange(1, 65536));
  serve_cmd->add_option("--deforms-per-second", c.deforms_per_second, "Rate limit per client")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 1e6, Bound::kOpen));
  serve_cmd->add_option("--deform-burst", c.deform_burst, "Rate limit burst")
      ->capture_default_str()
      ->check(cli::FiniteRange(1, 1e6));
  auto* tls_cert = serve_cmd->add_option("--tls-cert", c.tls_cert_file,
                                         "TLS for client connections: the certificate chain (PEM)");
  auto* tls_key = serve_cmd->add_option("--tls-key", c.tls_key_file, "The certificate's private key (PEM)");
  tls_cert->needs(tls_key);
  tls_key->needs(tls_cert);
  serve_cmd
      ->add_option("--metrics-bind", c.metrics_bind,
                   "HOST:PORT for Prometheus metrics over HTTP (GET /metrics); empty: none")
      ->capture_default_str();
  serve_cmd
      ->add_option("--max-stamp-cost", c.max_stamp_cost,
                   "Sample updates one stamp may cost (a shockwave's times its steps)")
      ->capture_default_str()
      ->check(cli::IntRange(1, int64_t(1) << 50));
  serve_cmd
      ->add_option("--stamp-cost-per-second", c.stamp_cost_per_second,
                   "Per client: sample updates a second of stamps")
      ->capture_default_str()
      ->check(cli::IntRange(1, int64_t(1) << 50));
  serve_cmd
      ->add_option("--tick-stamp-cost", c.tick_stamp_cost,
                   "Sample updates applied per tick, all clients (at least one stamp)")
      ->capture_default_str()
      ->check(cli::IntRange(1, int64_t(1) << 50));
  serve_cmd
      ->add_option("--apply-wait-ms", c.apply_wait_ms,
                   "How long a tick waits for its stamps to be applied (off the I/O thread) before going on")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 1000));
  serve_cmd
      ->add_option("--requests-per-second", c.requests_per_second,
                   "Per client: Subscribe, Unsubscribe, Ping, StampImageRequest and StatsRequest")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 1e6, Bound::kOpen));
  serve_cmd->add_option("--request-burst", c.request_burst, "Per client: request bucket capacity")
      ->capture_default_str()
      ->check(cli::FiniteRange(1, 1e6));
  serve_cmd->add_option("--handshake-timeout", c.handshake_timeout_s, "Seconds")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 3600, Bound::kOpen));
  serve_cmd->add_option("--idle-timeout", c.idle_timeout_s, "Seconds (0: none)")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 604800));
  serve_cmd->add_option("--max-queue-bytes", c.max_queue_bytes, "Per-client send queue bound")
      ->capture_default_str()
      ->check(cli::IntRange(65536, int64_t(1) << 40));
  serve_cmd
      ->add_option("--client-budget", c.client_bytes_per_second,
                   "Bytes per second of regions to each client (0: no limit); acks and events go outside it")
      ->capture_default_str()
      ->check(cli::IntRange(0, int64_t(1) << 31));
  serve_cmd
      ->add_option("--max-encodes-per-tick", c.max_encodes_per_tick, "Regions encoded per tick, all clients")
      ->capture_default_str()
      ->check(cli::IntRange(1, 1 << 20));
  serve_cmd
      ->add_option("--region-cache-bytes", c.region_cache_bytes, "Encoded regions kept for other clients")
      ->capture_default_str()
      ->check(cli::IntRange(0, int64_t(1) << 40));
  serve_cmd
      ->add_option("--best-after-uses", c.best_after_uses,
                   "Re-encode a whole tile in the best mode once sent this often (0: never)")
      ->capture_default_str()
      ->check(cli::IntRange(0, 1 << 20));
  serve_cmd
      ->add_option("--history-bytes", c.history_bytes,
                   "Samples kept of recent changes, for delta patches to clients behind")
      ->capture_default_str()
      ->check(cli::IntRange(0, int64_t(1) << 40));
  serve_cmd->add_option("--snapshot-every", c.snapshot_every_stamps, "Stamps between snapshots (0: off)")
      ->capture_default_str()
      ->check(cli::IntRange(0, int64_t(1) << 40));
  serve_cmd->add_option("--snapshot-interval", c.snapshot_interval_s, "Seconds between snapshots (0: off)")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 1e7));
  serve_cmd
      ->add_option("--prefetch-tiles", c.prefetch_tiles,
                   "Base tiles (refined or from a pack) made ahead on a worker thread, for stamps admitted "
                   "and tiles subscribed before the tick reads them (0: off)")
      ->capture_default_str()
      ->check(cli::IntRange(0, 1 << 16));
  o->dirty_mb = c.snapshot_dirty_bytes >> 20;
  serve_cmd
      ->add_option("--snapshot-dirty-mb", o->dirty_mb,
                   "A snapshot is due when edited tiles no snapshot holds reach this many MiB (they stay in "
                   "memory until one does; 0: no such trigger)")
      ->capture_default_str()
      ->check(cli::IntRange(0, 1 << 20));
  serve_cmd
      ->add_option(
          "--keep-snapshots", c.keep_snapshots,
          "Retention: the newest snapshots kept (older ones and the tiles only they name are removed)")
      ->capture_default_str()
      ->check(cli::IntRange(1, 1000));
  serve_cmd
      ->add_option("--log-retention-mb", o->log_retention,
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
  serve_cmd->add_option("--hashes-every", c.hashes_every_ticks, "Ticks between TileHashes (0: never)")
      ->capture_default_str()
      ->check(cli::IntRange(0, 1000000));
  serve_cmd->add_option("--stats-interval", c.stats_interval_s, "Seconds between stats lines (0: off)")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, 1e7));
  serve_cmd->add_option("--max-radius", c.stamp_limits.max_radius_samples, "Stamp radius cap in samples")
      ->capture_default_str()
      ->check(cli::FiniteRange(0, kHardMaxRadiusSamples, Bound::kOpen));
}

}  // namespace

Command add_serve(CLI::App& app) {
  auto o = std::make_shared<ServeOptions>();
  auto* serve_cmd = app.add_subcommand("serve", "Run a terrain session over TCP");
  add_serve_options(serve_cmd, o.get());
  return {serve_cmd, [o] {
            ServerConfig config = o->config;
            config.snapshot_dirty_bytes = o->dirty_mb << 20;
            if (o->log_retention == "all") {
              config.log_retention_bytes = UINT64_MAX;
            } else {
              config.log_retention_bytes =
                  uint64_t(std::strtod(o->log_retention.c_str(), nullptr) * double(1 << 20));
            }
            return serve(config);
          }};
}

}  // namespace loam::server::cmd
