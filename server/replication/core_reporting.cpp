// Reporting, part of ReplicationCore: the tick times the transport measured, every number the
// server reports gathered from the counters table (counters.h) for /metrics, the stats line and
// the Stats message.
#include <algorithm>
#include <cstdio>

#include "server/replication/core_detail.h"
#include "server/replication/replication_core.h"

namespace loam::server {

using namespace core_detail;

namespace {

// The one percentile rule of the stats line and the Stats message (nearest rank below), so
// the two never disagree on the same ticks. `sorted` ascending; 0 when empty.
double percentile(const std::vector<double>& sorted, double p) {
  return sorted.empty() ? 0.0 : sorted[size_t(p * double(sorted.size() - 1))];
}

std::string fmt_ms(double ms) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", ms);
  return buf;
}

}  // namespace

void ReplicationCore::record_tick(const TickTimes& p) {
  const double ms = p.total_ms;
  tick_ms_.push_back(ms);
  ticks_.add(ms);
  if (ms > 1000.0 / config_.tick_hz) {
    ++stats_.tick_overruns;
    note("tick_overrun", {{"tick", std::to_string(tick_)},
                          {"ms", fmt_ms(ms)},
                          {"stamps", std::to_string(last_batch_)},
                          {"sync_ms", fmt_ms(p.sync_ms)},
                          {"commit_ms", fmt_ms(p.commit_ms)},
                          {"apply_wait_ms", fmt_ms(p.apply_wait_ms)},
                          {"applying", p.world_busy ? "yes" : "no"},
                          {"stream_ms", fmt_ms(p.stream_ms)},
                          {"snapshot_ms", fmt_ms(p.snapshot_ms)},
                          {"trim_ms", fmt_ms(p.trim_ms)},
                          {"base_tiles_read", std::to_string(tick_base_tiles_read_)},
                          {"edited_tiles_loaded", std::to_string(tick_edited_tiles_loaded_)}});
  }
}

MetricsSnapshot ReplicationCore::metrics() const {
  MetricsSnapshot m;
  // The counters (counters.h): the core's own and the transport's, as they stand.
#define LOAM_COUNTER_COPY_core(name) m.name = stats_.name;
#define LOAM_COUNTER_COPY_transport(name) m.name = transport_->name;
#define LOAM_COUNTER_COPY_state(name)
#define LOAM_X(name, source, line, metric, type, help, wire) LOAM_COUNTER_COPY_##source(name)
  LOAM_SERVER_COUNTERS(LOAM_X)
#undef LOAM_X
#undef LOAM_COUNTER_COPY_core
#undef LOAM_COUNTER_COPY_transport
#undef LOAM_COUNTER_COPY_state
  m.deforms_rejected_by = stats_.deforms_rejected_by;
  // The rows read from the core's state.
  m.sessions = admission_.sessions();
  m.handshakes = admission_.handshakes();
  m.clients = clients_.size();
  m.seq = commits_.published_seq();
  const RegionFrameCounters& rc = streamer_.frames().counters();
  m.region_encodes = rc.encodes;
  m.region_cache_hits = rc.hits;
  m.region_deltas = rc.delta_encodes;
  m.region_best_upgrades = rc.best_upgrades;
  m.region_best_bytes_saved = rc.best_bytes_saved;
  m.region_cache_bytes = rc.bytes_held;
  m.history_bytes = history_.bytes();
  m.edited_tile_bytes = world_counters_.edited_bytes;
  m.base_cache_bytes = world_counters_.base_cache_bytes;
  m.base_tiles_generated = world_counters_.base_tiles_generated;
  m.unpersisted_tile_bytes = world_counters_.unpersisted_bytes;
  m.edited_tiles_loaded = world_counters_.edited_tiles_loaded;
  if (prefetch_) {
    const PrefetchingBase::Stats ps = prefetch_->stats();
    m.prefetch_queued = ps.queued;
    m.prefetch_hits = ps.ready_hits;
    m.prefetch_inline = ps.made_inline;
  }
  m.snapshot_store_bytes = storage_.store().file_bytes();
  m.snapshot_live_bytes = storage_.store().live_bytes();
  m.pending_deforms = commits_.queued().size();
  for (const PendingDeform& p : commits_.queued()) m.pending_stamp_cost += p.cost;
  m.snapshot_sequence = storage_.last_snapshot_seq();
  m.ticks = ticks_;
  return m;
}

void ReplicationCore::report_stats(CoreTime) {
  std::vector<double> t = std::move(tick_ms_);
  tick_ms_.clear();
  std::sort(t.begin(), t.end());
  last_p50_ms_ = percentile(t, 0.5);
  last_p99_ms_ = percentile(t, 0.99);
  // The counters from the table; the tick percentiles and the storage's state between them.
  const auto fields =
      stats_line_fields(metrics(), {{27, "tick_p50_ms", std::to_string(last_p50_ms_)},
                                    {28, "tick_p99_ms", std::to_string(last_p99_ms_)},
                                    {29, "storage", storage_.writable() ? "ok" : "refusing edits"}});
  note("stats", fields);
}

namespace {

// wire::Stats with a field that takes the table's rows that are not sent (wire `none`).
struct StatsFields : wire::Stats {
  uint64_t none = 0;
};

}  // namespace

wire::Stats ReplicationCore::stats_message(uint32_t request_id, CoreTime now) const {
  const MetricsSnapshot m = metrics();
  StatsFields st;
#define LOAM_X(name, source, line, metric, type, help, wire) st.wire = decltype(st.wire)(m.name);
  LOAM_SERVER_COUNTERS(LOAM_X)
#undef LOAM_X
  st.request_id = request_id;
  // Without a completed stats period yet, report the ticks so far.
  double p50 = last_p50_ms_, p99 = last_p99_ms_;
  if (p50 == 0 && !tick_ms_.empty()) {
    std::vector<double> t = tick_ms_;
    std::sort(t.begin(), t.end());
    p50 = percentile(t, 0.5);
    p99 = percentile(t, 0.99);
  }
  st.tick_p50_us = uint32_t(p50 * 1000.0);
  st.tick_p99_us = uint32_t(p99 * 1000.0);
  st.uptime_ms = uint64_t(std::chrono::duration_cast<std::chrono::milliseconds>(now - started_).count());
  st.client_bytes_per_second = config_.client_bytes_per_second;
  return st;
}

}  // namespace loam::server
