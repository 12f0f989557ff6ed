// The server's metrics in the Prometheus text exposition format (version 0.0.4): what
// `--metrics-bind` serves at /metrics (metrics_http.h) for a scraper. Pure: the caller gathers
// the numbers, this formats them, so the format is unit-tested without a socket.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "server/counters.h"

namespace loam::server {

// Tick durations, cumulative since start, in the fixed buckets a Prometheus histogram needs.
struct TickHistogram {
  static constexpr std::array<double, 11> kBoundsMs = {1, 2, 5, 10, 20, 33, 50, 100, 200, 500, 1000};
  std::array<uint64_t, kBoundsMs.size()> counts{};  // ticks at or under each bound (not cumulative)
  uint64_t count = 0;
  double sum_ms = 0;
  void add(double ms);
};

// Every number the server reports (counters.h: one field per row), gathered at one moment.
struct MetricsSnapshot {
#define LOAM_X(name, source, line, metric, type, help, wire) uint64_t name = 0;
  LOAM_SERVER_COUNTERS(LOAM_X)
#undef LOAM_X
  std::map<std::string, uint64_t> deforms_rejected_by;  // by reason (wire error code name)
  TickHistogram ticks;
};

// The /metrics text: every row of counters.h with a metric name, in the table's order, then the
// tick histogram.
std::string prometheus_text(const MetricsSnapshot& m);

// The periodic `stats` log line's fields: the rows of counters.h with a line position, in that
// order, and `extra` (fields that are not counters: tick percentiles, the storage's state) at
// the positions they name.
struct StatsLineExtra {
  int line = 0;
  const char* key = "";
  std::string value;
};
std::vector<std::pair<const char*, std::string>> stats_line_fields(const MetricsSnapshot& m,
                                                                   const std::vector<StatsLineExtra>& extra);

}  // namespace loam::server
