// TokenBucket (server/replication/token_bucket.h): refills from the time it is given, up to its
// capacity; takes only what it holds; spends into debt; says when it will hold enough.
#include "server/replication/token_bucket.h"

#include <gtest/gtest.h>

namespace loam::server {
namespace {

using namespace std::chrono_literals;

const CoreTime kBucketStart = CoreTime{} + 100s;

TEST(TokenBucket, RefillsAtItsRateFromTheTimeGivenUpToItsCapacity) {
  TokenBucket b(10.0, 5.0, 0.0, kBucketStart);
  EXPECT_EQ(b.level(), 0.0);
  EXPECT_DOUBLE_EQ(b.level_at(kBucketStart + 200ms), 2.0);
  EXPECT_EQ(b.level(), 0.0) << "level_at must not refill";
  b.refill(kBucketStart + 200ms);
  EXPECT_DOUBLE_EQ(b.level(), 2.0);
  b.refill(kBucketStart + 10s);
  EXPECT_EQ(b.level(), 5.0);
  // Time that does not move adds nothing.
  b.refill(kBucketStart + 10s);
  EXPECT_EQ(b.level(), 5.0);
}

TEST(TokenBucket, TakesOnlyWhatItHoldsAndTakesNothingOtherwise) {
  TokenBucket b(1.0, 3.0, 3.0, kBucketStart);
  EXPECT_TRUE(b.take(1.0));
  EXPECT_TRUE(b.take(2.0));
  EXPECT_FALSE(b.holds(1.0));
  EXPECT_FALSE(b.take(0.5));
  EXPECT_EQ(b.level(), 0.0);
}

TEST(TokenBucket, SpendingPastZeroIsADebtPaidBackBeforeTheLevelRises) {
  TokenBucket credit(1000.0, 1000.0, 0.0, kBucketStart);
  credit.spend(1500.0);
  EXPECT_EQ(credit.level(), -1500.0);
  credit.refill(kBucketStart + 1s);
  EXPECT_DOUBLE_EQ(credit.level(), -500.0);
  credit.refill(kBucketStart + 2s);
  EXPECT_DOUBLE_EQ(credit.level(), 500.0);
}

TEST(TokenBucket, SaysWhenItWillHoldATokenAndNothingWhenItHoldsOneNow) {
  TokenBucket b(4.0, 10.0, 0.0, kBucketStart);
  const auto at = b.holds_at(1.0, kBucketStart);
  ASSERT_TRUE(at.has_value());
  EXPECT_EQ(*at, kBucketStart + 250ms);
  EXPECT_FALSE(b.holds_at(1.0, kBucketStart + 250ms).has_value());
  // A bucket with no rate never refills: nothing to wait for.
  EXPECT_FALSE(TokenBucket(0.0, 1.0, 0.0, kBucketStart).holds_at(1.0, kBucketStart).has_value());
}

}  // namespace
}  // namespace loam::server
