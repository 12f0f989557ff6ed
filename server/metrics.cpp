#include "server/metrics.h"

#include <cstdio>

namespace loam::server {

void TickHistogram::add(double ms) {
  ++count;
  sum_ms += ms;
  for (size_t i = 0; i < kBoundsMs.size(); ++i) {
    if (ms <= kBoundsMs[i]) {
      ++counts[i];
      return;
    }
  }
}

namespace {

std::string number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.15g", v);
  return buf;
}

void metric(std::string& out, const char* name, const char* type, const char* help, uint64_t value) {
  out += std::string("# HELP ") + name + " " + help + "\n# TYPE " + name + " " + type + "\n" + name + " " +
         std::to_string(value) + "\n";
}

}  // namespace

std::string prometheus_text(const MetricsSnapshot& m) {
  std::string out;
  metric(out, "loam_clients", "gauge", "Clients in session (through Hello).", m.sessions);
  metric(out, "loam_handshakes", "gauge", "Connections that have not said Hello yet.", m.handshakes);
  metric(out, "loam_connects_total", "counter", "Connections accepted.", m.connects);
  metric(out, "loam_disconnects_total", "counter", "Connections closed.", m.disconnects);
  metric(out, "loam_tls_handshake_failures_total", "counter",
         "Connections closed because their TLS handshake failed (a client without TLS, or a bad one).",
         m.tls_handshake_failures);
  metric(out, "loam_sequence", "gauge", "Global sequence number of the last stamp.", m.sequence);
  metric(out, "loam_deforms_accepted_total", "counter", "Deforms accepted.", m.deforms_accepted);
  out +=
      "# HELP loam_deforms_rejected_total Deforms refused, by reason.\n"
      "# TYPE loam_deforms_rejected_total counter\n";
  for (const auto& [reason, n] : m.deforms_rejected)
    out += "loam_deforms_rejected_total{reason=\"" + reason + "\"} " + std::to_string(n) + "\n";
  metric(out, "loam_requests_refused_total", "counter", "Requests over a client's rate, dropped.",
         m.requests_refused);
  metric(out, "loam_violations_total", "counter", "Errors sent for a client's fault.", m.violations);
  metric(out, "loam_bytes_in_total", "counter", "Bytes read from clients.", m.bytes_in);
  metric(out, "loam_bytes_out_total", "counter", "Bytes written to clients.", m.bytes_out);
  metric(out, "loam_events_sent_total", "counter", "DeformEvents sent.", m.events_sent);
  metric(out, "loam_regions_sent_total", "counter", "RegionUpdates sent (whole tiles and patches).",
         m.regions_sent);
  metric(out, "loam_patches_sent_total", "counter", "RegionUpdates that were patches.",
         m.partial_regions_sent);
  metric(out, "loam_region_encodes_total", "counter", "Regions encoded.", m.region_encodes);
  metric(out, "loam_region_cache_hits_total", "counter", "Regions served from the encode-once cache.",
         m.region_cache_hits);
  metric(out, "loam_region_deltas_total", "counter", "Patches coded against the samples a client holds.",
         m.region_deltas);
  metric(out, "loam_region_best_upgrades_total", "counter", "Whole tiles re-encoded in the best mode.",
         m.region_best_upgrades);
  metric(out, "loam_region_cache_bytes", "gauge", "Encoded regions held for other clients.",
         m.region_cache_bytes);
  metric(out, "loam_history_bytes", "gauge", "Replaced samples kept for delta patches.", m.history_bytes);
  metric(out, "loam_edited_tile_bytes", "gauge",
         "Samples of edited tiles held in memory (those a snapshot holds are evicted under --cache-mb).",
         m.edited_tile_bytes);
  metric(out, "loam_base_cache_bytes", "gauge", "Clean base tiles held in memory (--cache-mb).",
         m.base_cache_bytes);
  metric(out, "loam_unpersisted_tile_bytes", "gauge",
         "Samples of edited tiles no snapshot holds yet (a snapshot is due at --snapshot-dirty-mb).",
         m.unpersisted_tile_bytes);
  metric(out, "loam_edited_tiles_loaded_total", "counter",
         "Evicted edited tiles read back from the snapshot store.", m.edited_tiles_loaded);
  metric(out, "loam_snapshots_total", "counter", "Snapshots written since start.", m.snapshots);
  metric(out, "loam_prefetch_queued_total", "counter",
         "Base tiles queued to be made ahead (--prefetch-tiles).", m.prefetch_queued);
  metric(out, "loam_prefetch_hits_total", "counter", "Base tile reads answered by a tile made ahead.",
         m.prefetch_hits);
  metric(out, "loam_prefetch_inline_total", "counter", "Base tile reads made on the tick thread.",
         m.prefetch_inline);
  metric(out, "loam_snapshot_written_bytes_total", "counter", "Bytes snapshots wrote since start.",
         m.snapshot_bytes_written);
  metric(out, "loam_snapshot_store_bytes", "gauge", "Tiles files the newest snapshot names.",
         m.snapshot_store_bytes);
  metric(out, "loam_snapshot_live_bytes", "gauge", "Records in those files the newest snapshot uses.",
         m.snapshot_live_bytes);
  metric(out, "loam_base_tiles_generated_total", "counter", "Base tiles generated or read so far.",
         m.base_tiles_generated);
  metric(out, "loam_pending_deforms", "gauge", "Deforms admitted and waiting for a tick.", m.pending_deforms);
  metric(out, "loam_pending_stamp_cost", "gauge", "Sample updates of the deforms waiting for a tick.",
         m.pending_stamp_cost);
  metric(out, "loam_max_queue_bytes", "gauge", "The largest send queue of any client.", m.max_queue_bytes);
  metric(out, "loam_tick_overruns_total", "counter", "Ticks longer than their period.", m.tick_overruns);
  metric(out, "loam_storage_failures_total", "counter", "Log syncs that failed (edits refused meanwhile).",
         m.storage_failures);
  metric(out, "loam_snapshot_sequence", "gauge", "Sequence number of the newest snapshot.",
         m.snapshot_sequence);
  out +=
      "# HELP loam_tick_seconds Tick durations.\n"
      "# TYPE loam_tick_seconds histogram\n";
  uint64_t cumulative = 0;
  for (size_t i = 0; i < TickHistogram::kBoundsMs.size(); ++i) {
    cumulative += m.ticks.counts[i];
    out += "loam_tick_seconds_bucket{le=\"" + number(TickHistogram::kBoundsMs[i] / 1000.0) + "\"} " +
           std::to_string(cumulative) + "\n";
  }
  out += "loam_tick_seconds_bucket{le=\"+Inf\"} " + std::to_string(m.ticks.count) + "\n";
  out += "loam_tick_seconds_sum " + number(m.ticks.sum_ms / 1000.0) + "\n";
  out += "loam_tick_seconds_count " + std::to_string(m.ticks.count) + "\n";
  return out;
}

}  // namespace loam::server
