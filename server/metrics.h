// The server's metrics in the Prometheus text exposition format (version 0.0.4): what
// `--metrics-bind` serves at /metrics (metrics_http.h) for a scraper. Pure: the caller gathers
// the numbers, this formats them, so the format is unit-tested without a socket.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>

namespace loam::server {

// Tick durations, cumulative since start, in the fixed buckets a Prometheus histogram needs.
struct TickHistogram {
  static constexpr std::array<double, 11> kBoundsMs = {1, 2, 5, 10, 20, 33, 50, 100, 200, 500, 1000};
  std::array<uint64_t, kBoundsMs.size()> counts{};  // ticks at or under each bound (not cumulative)
  uint64_t count = 0;
  double sum_ms = 0;
  void add(double ms);
};

struct MetricsSnapshot {
  uint64_t sessions = 0, handshakes = 0;  // clients in session; connections before Hello
  uint64_t connects = 0, disconnects = 0;
  uint64_t tls_handshake_failures = 0;  // connections closed before their TLS handshake completed
  uint64_t sequence = 0;                // the last stamp's global sequence
  uint64_t deforms_accepted = 0;
  std::map<std::string, uint64_t> deforms_rejected;  // by reason (wire error code name)
  uint64_t requests_refused = 0, violations = 0;
  uint64_t bytes_in = 0, bytes_out = 0;
  uint64_t events_sent = 0, regions_sent = 0, partial_regions_sent = 0;
  uint64_t region_encodes = 0, region_cache_hits = 0, region_deltas = 0, region_best_upgrades = 0;
  uint64_t region_cache_bytes = 0, history_bytes = 0;
  // The world: samples of edited tiles, clean base tiles cached, base tiles generated so far.
  uint64_t edited_tile_bytes = 0, base_cache_bytes = 0, base_tiles_generated = 0;
  // Edited tiles no snapshot holds yet (not evictable), and edited tiles read back from the store.
  uint64_t unpersisted_tile_bytes = 0, edited_tiles_loaded = 0;
  uint64_t snapshots = 0, snapshot_bytes_written = 0;  // since start
  // Base tiles made ahead by the prefetcher: queued, answered from it, made on the tick thread.
  uint64_t prefetch_queued = 0, prefetch_hits = 0, prefetch_inline = 0;
  uint64_t snapshot_store_bytes = 0, snapshot_live_bytes = 0;  // the tiles files the newest snapshot names
  uint64_t pending_deforms = 0, pending_stamp_cost = 0;        // waiting for a tick
  uint64_t max_queue_bytes = 0;                                // the largest client send queue
  uint64_t tick_overruns = 0, storage_failures = 0;
  uint64_t snapshot_sequence = 0;
  TickHistogram ticks;
};

std::string prometheus_text(const MetricsSnapshot& m);

}  // namespace loam::server
