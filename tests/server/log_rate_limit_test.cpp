// The rate limit on log lines a client can cause (server/log_rate_limit.h), with made-up time.
#include "server/log_rate_limit.h"

#include <gtest/gtest.h>

namespace loam::server {
namespace {

TEST(LogRateLimit, AFloodOfOneKindIsCutToItsRateAndTheDroppedLinesAreCounted) {
  LogRateLimit limit(10.0, 5.0);
  int emitted = 0;
  for (int i = 0; i < 1000; ++i) emitted += limit.admit("connect", 100.0).emit;  // one instant
  EXPECT_EQ(emitted, 5);                                                         // the burst
  // Other kinds have buckets of their own.
  EXPECT_TRUE(limit.admit("violation", 100.0).emit);
  // A second later the bucket is full again (5); the first line says how many went unwritten.
  const LogRateLimit::Verdict v = limit.admit("connect", 101.0);
  EXPECT_TRUE(v.emit);
  EXPECT_EQ(v.suppressed, 995u);
  for (int i = 0; i < 20; ++i) limit.admit("connect", 101.0);
  const auto summary = limit.take_suppressed();
  ASSERT_EQ(summary.size(), 1u);
  EXPECT_EQ(summary[0].first, "connect");
  EXPECT_EQ(summary[0].second, 16u);  // 4 of the 20 fit in what was left of the bucket
  EXPECT_TRUE(limit.take_suppressed().empty());
}

TEST(LogRateLimit, LinesWithinTheRateAreAllWritten) {
  LogRateLimit limit(20.0, 200.0);
  for (int i = 0; i < 10000; ++i) EXPECT_TRUE(limit.admit("hello", i * 0.05).emit) << i;  // 20 a second
  EXPECT_TRUE(limit.take_suppressed().empty());
}

}  // namespace
}  // namespace loam::server
