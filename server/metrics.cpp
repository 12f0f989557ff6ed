#include "server/metrics.h"

#include <algorithm>
#include <cstdio>
#include <string_view>

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

struct Row {
  const char* name;
  int line;
  const char* metric;
  const char* type;  // counter, gauge or by_reason
  const char* help;
  uint64_t MetricsSnapshot::*field;
};

// counters.h, as data.
constexpr Row kRows[] = {
#define LOAM_X(name, source, line, metric, type, help, wire) \
  {#name, line, metric, #type, help, &MetricsSnapshot::name},
    LOAM_SERVER_COUNTERS(LOAM_X)
#undef LOAM_X
};

}  // namespace

std::string prometheus_text(const MetricsSnapshot& m) {
  std::string out;
  for (const Row& r : kRows) {
    if (*r.metric == '\0') continue;
    if (std::string_view(r.type) != "by_reason") {
      metric(out, r.metric, r.type, r.help, m.*r.field);
      continue;
    }
    out += std::string("# HELP ") + r.metric + " " + r.help + "\n# TYPE " + r.metric + " counter\n";
    for (const auto& [reason, n] : m.deforms_rejected_by)
      out += std::string(r.metric) + "{reason=\"" + reason + "\"} " + std::to_string(n) + "\n";
  }
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

std::vector<std::pair<const char*, std::string>> stats_line_fields(const MetricsSnapshot& m,
                                                                   const std::vector<StatsLineExtra>& extra) {
  int last = 0;
  for (const Row& r : kRows) last = std::max(last, r.line);
  for (const StatsLineExtra& e : extra) last = std::max(last, e.line);
  std::vector<std::pair<const char*, std::string>> out;
  for (int line = 1; line <= last; ++line) {
    for (const Row& r : kRows)
      if (r.line == line) out.emplace_back(r.name, std::to_string(m.*r.field));
    for (const StatsLineExtra& e : extra)
      if (e.line == line) out.emplace_back(e.key, e.value);
  }
  return out;
}

}  // namespace loam::server
