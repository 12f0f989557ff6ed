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
  m.deforms_rejected = {{"rate_limited", 4}, {"oversize", 1}};
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

}  // namespace
}  // namespace loam::server
