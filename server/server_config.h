// Everything `loam-server serve` can be told, with defaults. docs/configuration.md
// documents each option; the CLI flags and the optional config file (INI/TOML, read by
// CLI11) set the same fields.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "dem/dem_georef.h"
#include "dem/nodata_fill.h"
#include "protocol/stamps/stamp_validate.h"

namespace loam::server {

struct ServerConfig {
  std::string bind_address = "127.0.0.1";
  uint16_t port = 7878;   // 0: an ephemeral port (see port_file)
  std::string port_file;  // when set, the bound port is written there once listening
  // TLS for client connections: the certificate chain and its key (PEM). Both or neither.
  std::string tls_cert_file, tls_key_file;
  std::string metrics_bind;      // HOST:PORT of the Prometheus /metrics endpoint; empty: none
  std::string dem_path;          // empty: the embedded terrain `terrain` names
  std::string terrain = "crop";  // crop | refined (server/terrain_source.h)
  uint32_t prefetch_tiles = 64;  // base tiles made ahead off the tick thread (0: off)
  uint64_t cache_mb = 256;       // clean tiles kept in memory: the base's and persisted edits
  int dem_band = 0;              // the DEM's height band (1-based); 0: its only band
  NodataFill nodata_fill;        // what the DEM's NoData samples become
  LocalProjection project = LocalProjection::kNone;  // a geographic DEM warped to metres first
  std::vector<std::string> stamp_images;             // texture-stamp image files to register
  std::string data_dir = "loam-data";
  std::string backend = "cpu";  // auto | gpu | cpu
  uint32_t tick_hz = 30;
  // Access: with any token configured, a client must present one (hex, 32 digits) in Hello.
  // Checked at start (load_access_tokens); a Server given unreadable tokens lets nobody in.
  std::vector<std::string> editor_tokens;
  std::vector<std::string> viewer_tokens;
  std::string tokens_file;  // more tokens, `editor HEX` / `viewer HEX` lines (server/access_tokens.h)
  // Limits.
  uint32_t max_clients = 64;                 // clients in session (through Hello)
  uint32_t max_handshakes = 64;              // connections not yet through Hello, all addresses
  uint32_t max_handshakes_per_address = 16;  // the same, from one address
  uint32_t max_frame_bytes = 1u << 20;
  uint32_t max_subscriptions = 4096;
  uint32_t max_pending_deforms = 64;  // per client: queued deforms not yet acknowledged
  double deforms_per_second = 60.0;   // token bucket rate per client
  double deform_burst = 120.0;        // token bucket capacity
  // Stamps by cost (stamp_cost: sample updates, a shockwave's times its steps): a stamp over
  // max_stamp_cost is refused; a client's stamps draw on a bucket of stamp_cost_per_second
  // (capacity: the larger of it and max_stamp_cost); a tick applies stamps up to
  // tick_stamp_cost (at least one), the rest wait for the next tick in order.
  uint64_t max_stamp_cost = 1ull << 24;
  uint64_t stamp_cost_per_second = 1ull << 24;
  uint64_t tick_stamp_cost = 1ull << 22;
  // Stamps are applied on a worker thread; a tick waits this long for the apply (so events
  // leave in the same tick as the acks when it is quick) before going on without it.
  double apply_wait_ms = 5.0;
  // Every other request (Subscribe, Unsubscribe, Ping, StampImageRequest, StatsRequest): a
  // token bucket per client, so that re-subscribing or pinging in a loop cannot take the tick.
  double requests_per_second = 30.0;
  double request_burst = 120.0;
  double handshake_timeout_s = 5.0;
  double idle_timeout_s = 60.0;
  uint64_t max_queue_bytes = 32u << 20;  // a client whose unsent data exceeds this is dropped
  // Streaming: each client's bulk (regions) leaves at up to this many bytes per second; acks,
  // events, pongs and errors go at once, outside it. 0: no limit.
  uint32_t client_bytes_per_second = 128u << 10;
  uint32_t max_encodes_per_tick = 32;         // regions encoded per tick, all clients together
  uint64_t region_cache_bytes = 32ull << 20;  // encoded regions kept for other clients
  uint32_t best_after_uses = 2;  // a whole tile sent this often is re-encoded in the best mode (0: never)
  // Resume: the last changes of recently changed tiles and the samples they replaced, so a
  // client back from a disconnect, or missing a shockwave, gets a delta against the version it
  // holds (~40 bytes a change plus the replaced samples, within history_bytes).
  uint32_t history_changes_per_tile = 64;
  uint32_t history_tiles = 16384;
  uint64_t history_bytes = 16ull << 20;
  // Persistence and reporting.
  uint64_t snapshot_every_stamps = 20000;  // 0: only at shutdown
  double snapshot_interval_s = 600.0;      // 0: only by count and at shutdown
  // A snapshot is also due when edited tiles no snapshot holds reach this many bytes (they
  // cannot be evicted until one does). 0: never for that reason.
  uint64_t snapshot_dirty_bytes = 16ull << 20;
  // Snapshots are written on a worker thread (the tick copies what changed); false: on the tick
  // thread (deterministic for tests that drive the core).
  bool async_snapshots = true;
  uint32_t keep_snapshots = 3;                       // retention: the newest snapshots kept
  uint64_t log_retention_bytes = uint64_t(1) << 30;  // covered segments go beyond this (UINT64_MAX: keep all)
  uint32_t hashes_every_ticks = 30;                  // TileHashes to each client (0: never)
  double stats_interval_s = 10.0;                    // 0: no periodic stats lines
  StampLimits stamp_limits;
};

}  // namespace loam::server
