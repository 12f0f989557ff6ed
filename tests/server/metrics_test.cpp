// The Prometheus text the server serves at /metrics (server/metrics.h): well-formed lines,
// counters by reason, and a cumulative tick histogram.
#include "server/metrics.h"

#include <gtest/gtest.h>

#include <sstream>

namespace loam::server {
namespace {

TEST(Metrics, EveryLineIsACommentOrASampleAndTheHistogramIsCumulative) {
  MetricsSnapshot m;
  m.sessions = 3;
  m.base_cache_bytes = 131072;
  m.deforms_accepted = 10;
  m.deforms_rejected_by = {{"rate_limited", 4}, {"oversize", 1}};
  for (const double ms : {0.5, 3.0, 3.0, 40.0, 5000.0}) m.ticks.add(ms);
  const std::string text = prometheus_text(m);
  std::istringstream in(text);
  std::string line;
  int samples = 0;
  while (std::getline(in, line)) {
    ASSERT_FALSE(line.empty());
    if (line.rfind("# HELP loam_", 0) == 0 || line.rfind("# TYPE loam_", 0) == 0) continue;
    // name{labels} value, the name starting loam_, the value a number.
    ASSERT_EQ(line.rfind("loam_", 0), 0u) << line;
    const size_t space = line.rfind(' ');
    ASSERT_NE(space, std::string::npos) << line;
    size_t used = 0;
    (void)std::stod(line.substr(space + 1), &used);
    EXPECT_EQ(used, line.size() - space - 1) << line;
    ++samples;
  }
  EXPECT_GT(samples, 30);
  EXPECT_NE(text.find("\nloam_clients 3\n"), std::string::npos);
  EXPECT_NE(text.find("\nloam_base_cache_bytes 131072\n"), std::string::npos);
  EXPECT_NE(text.find("\nloam_deforms_rejected_total{reason=\"rate_limited\"} 4\n"), std::string::npos);
  EXPECT_NE(text.find("\nloam_deforms_rejected_total{reason=\"oversize\"} 1\n"), std::string::npos);
  // 0.5 ms under 1 ms; two 3 ms under 5 ms; 40 ms under 50 ms; 5 s only in +Inf.
  EXPECT_NE(text.find("loam_tick_seconds_bucket{le=\"0.001\"} 1\n"), std::string::npos) << text;
  EXPECT_NE(text.find("loam_tick_seconds_bucket{le=\"0.002\"} 1\n"), std::string::npos);
  EXPECT_NE(text.find("loam_tick_seconds_bucket{le=\"0.005\"} 3\n"), std::string::npos);
  EXPECT_NE(text.find("loam_tick_seconds_bucket{le=\"0.05\"} 4\n"), std::string::npos);
  EXPECT_NE(text.find("loam_tick_seconds_bucket{le=\"1\"} 4\n"), std::string::npos);
  EXPECT_NE(text.find("loam_tick_seconds_bucket{le=\"+Inf\"} 5\n"), std::string::npos);
  EXPECT_NE(text.find("loam_tick_seconds_count 5\n"), std::string::npos);
  EXPECT_NE(text.find("loam_tick_seconds_sum 5.0465"), std::string::npos);
}

// The counters table (counters.h) is the one place a number is named: each metric is served
// once with its HELP and TYPE, and the stats line lists its rows by position with the extras
// slotted in where they say.
TEST(Metrics, TheCountersTableServesEachMetricOnceAndOrdersTheStatsLine) {
  MetricsSnapshot m;
  m.clients = 4;
  m.seq = 17;
  m.storage_failures = 2;
  const std::string text = prometheus_text(m);
  for (const char* name :
       {"loam_clients", "loam_sequence", "loam_storage_failures_total", "loam_deforms_rejected_total"}) {
    const std::string help = std::string("# HELP ") + name + " ";
    const size_t at = text.find(help);
    ASSERT_NE(at, std::string::npos) << name;
    EXPECT_EQ(text.find(help, at + 1), std::string::npos) << name << " served twice";
  }
  EXPECT_NE(text.find("\nloam_sequence 17\n"), std::string::npos);
  // Rows outside /metrics (clients: every connection) stay out of it.
  EXPECT_EQ(text.find("loam_clients 4"), std::string::npos);
  const auto line = stats_line_fields(m, {{2, "between", "x"}, {1000, "last", "y"}});
  ASSERT_GE(line.size(), 5u);
  EXPECT_STREQ(line[0].first, "clients");
  EXPECT_EQ(line[0].second, "4");
  EXPECT_STREQ(line[1].first, "seq");
  EXPECT_EQ(line[1].second, "17");
  EXPECT_STREQ(line[2].first, "between");
  EXPECT_STREQ(line.back().first, "last");
  EXPECT_STREQ(line[line.size() - 2].first, "storage_failures");
  EXPECT_EQ(line[line.size() - 2].second, "2");
}

}  // namespace
}  // namespace loam::server
