// TokenBucket (server/replication/token_bucket.h): refills from the time it is given, up to its
// capacity; takes only what it holds; spends into debt; says when it will hold enough.
#include "server/replication/token_bucket.h"

#include <gtest/gtest.h>

namespace loam::server {
namespace {

using namespace std::chrono_literals;

const CoreTime kStart = CoreTime{} + 100s;

TEST(TokenBucket, RefillsAtItsRateFromTheTimeGivenUpToItsCapacity) {
  TokenBucket b(10.0, 5.0, 0.0, kStart);
  EXPECT_EQ(b.level(), 0.0);
  EXPECT_DOUBLE_EQ(b.level_at(kStart + 200ms), 2.0);
  EXPECT_EQ(b.level(), 0.0) << "level_at must not refill";
  b.refill(kStart + 200ms);
  EXPECT_DOUBLE_EQ(b.level(), 2.0);
  b.refill(kStart + 10s);
  EXPECT_EQ(b.level(), 5.0);
  // Time that does not move adds nothing.
  b.refill(kStart + 10s);
  EXPECT_EQ(b.level(), 5.0);
}

TEST(TokenBucket, TakesOnlyWhatItHoldsAndTakesNothingOtherwise) {
  TokenBucket b(1.0, 3.0, 3.0, kStart);
  EXPECT_TRUE(b.take(1.0));
  EXPECT_TRUE(b.take(2.0));
  EXPECT_FALSE(b.holds(1.0));
  EXPECT_FALSE(b.take(0.5));
  EXPECT_EQ(b.level(), 0.0);
}

TEST(TokenBucket, SpendingPastZeroIsADebtPaidBackBeforeTheLevelRises) {
  TokenBucket credit(1000.0, 1000.0, 0.0, kStart);
  credit.spend(1500.0);
  EXPECT_EQ(credit.level(), -1500.0);
  credit.refill(kStart + 1s);
  EXPECT_DOUBLE_EQ(credit.level(), -500.0);
  credit.refill(kStart + 2s);
  EXPECT_DOUBLE_EQ(credit.level(), 500.0);
}

TEST(TokenBucket, SaysWhenItWillHoldATokenAndNothingWhenItHoldsOneNow) {
  TokenBucket b(4.0, 10.0, 0.0, kStart);
  const auto at = b.holds_at(1.0, kStart);
  ASSERT_TRUE(at.has_value());
  EXPECT_EQ(*at, kStart + 250ms);
  EXPECT_FALSE(b.holds_at(1.0, kStart + 250ms).has_value());
  // A bucket with no rate never refills: nothing to wait for.
  EXPECT_FALSE(TokenBucket(0.0, 1.0, 0.0, kStart).holds_at(1.0, kStart).has_value());
}

}  // namespace
}  // namespace loam::server
