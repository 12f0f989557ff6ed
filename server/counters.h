// Every number the server reports, defined once. One row per number generates its field in
// ServerStats (the counters the core increments), TransportCounters (the ones the transport
// counts), MetricsSnapshot (everything /metrics and the stats line read), its Prometheus line
// (metrics.cpp), its place in the periodic `stats` log line, and the wire::Stats field it fills
// (the Stats message's layout stays protocol/'s: the table only says which number goes where).
//
// LOAM_SERVER_COUNTERS(X) calls X(name, source, line, metric, type, help, wire) per row, in the
// order /metrics lists them:
//   name    the field in MetricsSnapshot (and ServerStats or TransportCounters), uint64_t;
//   source  core: the core counts it (ServerStats); transport: the transport counts it
//           (TransportCounters); state: read from the core's state when reported;
//   line    its position in the stats line (0: not in it);
//   metric  its Prometheus name ("": not served); type: counter, gauge, or by_reason (a counter
//           labelled by reason, from MetricsSnapshot::deforms_rejected_by);
//   wire    the wire::Stats field it fills (none: not sent).
#pragma once

#include <cstdint>
#include <map>
#include <string>

#define LOAM_SERVER_COUNTERS(X)                                                                              \
  X(sessions, state, 0, "loam_clients", gauge, "Clients in session (through Hello).", none)                  \
  X(handshakes, state, 0, "loam_handshakes", gauge, "Connections that have not said Hello yet.", none)       \
  X(connects, core, 0, "loam_connects_total", counter, "Connections accepted.", none)                        \
  X(disconnects, core, 0, "loam_disconnects_total", counter, "Connections closed.", none)                    \
  X(tls_handshake_failures, transport, 0, "loam_tls_handshake_failures_total", counter,                      \
    "Connections closed because their TLS handshake failed (a client without TLS, or a bad one).", none)     \
  X(seq, state, 2, "loam_sequence", gauge, "Global sequence number of the last stamp.", global_sequence)     \
  X(deforms_accepted, core, 3, "loam_deforms_accepted_total", counter, "Deforms accepted.",                  \
    deforms_accepted)                                                                                        \
  X(deforms_rejected, core, 4, "loam_deforms_rejected_total", by_reason, "Deforms refused, by reason.",      \
    deforms_rejected)                                                                                        \
  X(requests_refused, core, 6, "loam_requests_refused_total", counter,                                       \
    "Requests over a client's rate, dropped.", none)                                                         \
  X(violations, core, 5, "loam_violations_total", counter, "Errors sent for a client's fault.", violations)  \
  X(bytes_in, transport, 8, "loam_bytes_in_total", counter, "Bytes read from clients.", bytes_in)            \
  X(bytes_out, transport, 9, "loam_bytes_out_total", counter, "Bytes written to clients.", bytes_out)        \
  X(events_sent, core, 10, "loam_events_sent_total", counter, "DeformEvents sent.", events_sent)             \
  X(regions_sent, core, 11, "loam_regions_sent_total", counter,                                              \
    "RegionUpdates sent (whole tiles and patches).", regions_sent)                                           \
  X(partial_regions_sent, core, 12, "loam_patches_sent_total", counter, "RegionUpdates that were patches.",  \
    none)                                                                                                    \
  X(region_encodes, state, 13, "loam_region_encodes_total", counter, "Regions encoded.", region_encodes)     \
  X(region_cache_hits, state, 14, "loam_region_cache_hits_total", counter,                                   \
    "Regions served from the encode-once cache.", region_cache_hits)                                         \
  X(region_deltas, state, 15, "loam_region_deltas_total", counter,                                           \
    "Patches coded against the samples a client holds.", none)                                               \
  X(region_best_upgrades, state, 16, "loam_region_best_upgrades_total", counter,                             \
    "Whole tiles re-encoded in the best mode.", none)                                                        \
  X(region_cache_bytes, state, 0, "loam_region_cache_bytes", gauge,                                          \
    "Encoded regions held for other clients.", none)                                                         \
  X(history_bytes, state, 18, "loam_history_bytes", gauge, "Replaced samples kept for delta patches.", none) \
  X(edited_tile_bytes, state, 19, "loam_edited_tile_bytes", gauge,                                           \
    "Samples of edited tiles held in memory (those a snapshot holds are evicted under --cache-mb).", none)   \
  X(base_cache_bytes, state, 20, "loam_base_cache_bytes", gauge,                                             \
    "Clean base tiles held in memory (--cache-mb).", none)                                                   \
  X(unpersisted_tile_bytes, state, 22, "loam_unpersisted_tile_bytes", gauge,                                 \
    "Samples of edited tiles no snapshot holds yet (a snapshot is due at --snapshot-dirty-mb).", none)       \
  X(edited_tiles_loaded, state, 23, "loam_edited_tiles_loaded_total", counter,                               \
    "Evicted edited tiles read back from the snapshot store.", none)                                         \
  X(snapshots, core, 0, "loam_snapshots_total", counter, "Snapshots written since start.", none)             \
  X(prefetch_queued, state, 0, "loam_prefetch_queued_total", counter,                                        \
    "Base tiles queued to be made ahead (--prefetch-tiles).", none)                                          \
  X(prefetch_hits, state, 24, "loam_prefetch_hits_total", counter,                                           \
    "Base tile reads answered by a tile made ahead.", none)                                                  \
  X(prefetch_inline, state, 25, "loam_prefetch_inline_total", counter,                                       \
    "Base tile reads made on the tick thread.", none)                                                        \
  X(snapshot_bytes_written, core, 0, "loam_snapshot_written_bytes_total", counter,                           \
    "Bytes snapshots wrote since start.", none)                                                              \
  X(snapshot_store_bytes, state, 0, "loam_snapshot_store_bytes", gauge,                                      \
    "Tiles files the newest snapshot names.", none)                                                          \
  X(snapshot_live_bytes, state, 0, "loam_snapshot_live_bytes", gauge,                                        \
    "Records in those files the newest snapshot uses.", none)                                                \
  X(base_tiles_generated, state, 21, "loam_base_tiles_generated_total", counter,                             \
    "Base tiles generated or read so far.", none)                                                            \
  X(pending_deforms, state, 0, "loam_pending_deforms", gauge, "Deforms admitted and waiting for a tick.",    \
    none)                                                                                                    \
  X(pending_stamp_cost, state, 0, "loam_pending_stamp_cost", gauge,                                          \
    "Sample updates of the deforms waiting for a tick.", none)                                               \
  X(max_queue_bytes, transport, 26, "loam_max_queue_bytes", gauge, "The largest send queue of any client.",  \
    none)                                                                                                    \
  X(tick_overruns, core, 0, "loam_tick_overruns_total", counter, "Ticks longer than their period.",          \
    tick_overruns)                                                                                           \
  X(storage_failures, core, 30, "loam_storage_failures_total", counter,                                      \
    "Log syncs that failed (edits refused meanwhile).", none)                                                \
  X(snapshot_sequence, state, 0, "loam_snapshot_sequence", gauge, "Sequence number of the newest snapshot.", \
    none)                                                                                                    \
  /* Not served at /metrics: */                                                                              \
  X(clients, state, 1, "", gauge, "Connections, in their handshake or in session.", clients)                 \
  X(deforms_resent, core, 7, "", counter, "Deforms seen again after a reconnect: answered, not applied.",    \
    none)                                                                                                    \
  X(region_best_bytes_saved, state, 17, "", counter, "Bytes the best-mode re-encodes saved.", none)

namespace loam::server {

// The counters the core increments.
struct ServerStats {
#define LOAM_COUNTER_FIELD_core(name) uint64_t name = 0;
#define LOAM_COUNTER_FIELD_transport(name)
#define LOAM_COUNTER_FIELD_state(name)
#define LOAM_X(name, source, line, metric, type, help, wire) LOAM_COUNTER_FIELD_##source(name)
  LOAM_SERVER_COUNTERS(LOAM_X)
#undef LOAM_X
#undef LOAM_COUNTER_FIELD_core
#undef LOAM_COUNTER_FIELD_transport
#undef LOAM_COUNTER_FIELD_state
  std::map<std::string, uint64_t> deforms_rejected_by;  // by reason (wire error code name)
};

// The counters the transport keeps (it owns the sockets); the core reads them for Stats.
struct TransportCounters {
#define LOAM_COUNTER_FIELD_core(name)
#define LOAM_COUNTER_FIELD_transport(name) uint64_t name = 0;
#define LOAM_COUNTER_FIELD_state(name)
#define LOAM_X(name, source, line, metric, type, help, wire) LOAM_COUNTER_FIELD_##source(name)
  LOAM_SERVER_COUNTERS(LOAM_X)
#undef LOAM_X
#undef LOAM_COUNTER_FIELD_core
#undef LOAM_COUNTER_FIELD_transport
#undef LOAM_COUNTER_FIELD_state
};

}  // namespace loam::server
