// The client's Deform pacing (client/net/deform_pacer.h) with made-up time: never more
// unacknowledged Deforms than the Welcome allows, never faster than its rate, always in order.
#include "client/net/deform_pacer.h"

#include <gtest/gtest.h>

namespace loam::client {
namespace {

using namespace std::chrono_literals;
using Clock = DeformPacer::Clock;

QuantizedStamp any_stamp() {
  QuantizedStamp q;
  q.kind = StampKind::kGaussian;
  return q;
}

TEST(DeformPacer, ABacklogLeavesInOrderWithinTheUnacknowledgedCap) {
  DeformPacer p;
  const Clock::time_point t0{};
  p.set_limits(3, 0, t0);  // no rate limit: only the cap
  for (uint32_t s = 1; s <= 10; ++s) p.submit(s, any_stamp());
  auto sent = p.take_sendable(t0);
  ASSERT_EQ(sent.size(), 3u);
  EXPECT_EQ(sent[0].first, 1u);
  EXPECT_EQ(sent[2].first, 3u);
  EXPECT_TRUE(p.take_sendable(t0).empty());  // the cap is full until an ack
  EXPECT_FALSE(p.next_send_time().has_value());
  p.acknowledged(2);
  sent = p.take_sendable(t0);
  ASSERT_EQ(sent.size(), 1u);
  EXPECT_EQ(sent[0].first, 4u);
  EXPECT_EQ(p.queued(), 6u);
  EXPECT_EQ(p.unacked(), 3u);
  // A lost connection: the three in flight go back to the front, in order, before the queue.
  EXPECT_EQ(p.requeue_unacked(), 3u);
  EXPECT_EQ(p.unacked(), 0u);
  sent = p.take_sendable(t0);
  ASSERT_EQ(sent.size(), 3u);
  EXPECT_EQ(sent[0].first, 1u);
  EXPECT_EQ(sent[1].first, 3u);
  EXPECT_EQ(sent[2].first, 4u);
}

TEST(DeformPacer, NoWindowSeesMoreThanTheRateAllowsPlusTwo) {
  DeformPacer p;
  const Clock::time_point t0 = Clock::time_point{} + 1h;
  p.set_limits(0, 10.0, t0);  // ten a second
  for (uint32_t s = 1; s <= 100; ++s) p.submit(s, any_stamp());
  std::vector<Clock::time_point> at;
  // Polled every 7 ms, sometimes late by up to 60 ms (a busy caller).
  Clock::time_point now = t0;
  for (int i = 0; i < 3000 && p.queued() > 0; ++i) {
    now += i % 50 == 49 ? 60ms : 7ms;
    for (const auto& d : p.take_sendable(now)) {
      at.push_back(now);
      p.acknowledged(d.first);
    }
  }
  ASSERT_EQ(at.size(), 100u);
  for (size_t i = 0; i < at.size(); ++i) {
    // Over any window [at[i], at[j]] of w seconds: at most 10 * w + 2 sends.
    for (size_t j = i; j < at.size(); ++j) {
      const double w = std::chrono::duration<double>(at[j] - at[i]).count();
      EXPECT_LE(double(j - i + 1), 10.0 * w + 2.0 + 1e-9) << i << ".." << j;
    }
  }
  // And it keeps up: 100 at ten a second take about ten seconds, not much more.
  EXPECT_LT(std::chrono::duration<double>(at.back() - t0).count(), 11.0);
}

TEST(DeformPacer, AfterIdlingTheNextDeformLeavesAtOnceButNoBurstIsBanked) {
  DeformPacer p;
  const Clock::time_point t0 = Clock::time_point{} + 1h;
  p.set_limits(0, 10.0, t0);
  const Clock::time_point later = t0 + 60s;
  for (uint32_t s = 1; s <= 5; ++s) p.submit(s, any_stamp());
  EXPECT_EQ(p.take_sendable(later).size(), 1u);
  ASSERT_TRUE(p.next_send_time().has_value());
  EXPECT_EQ(*p.next_send_time(), later + 100ms);
  EXPECT_EQ(p.take_sendable(later + 100ms).size(), 1u);
}

}  // namespace
}  // namespace loam::client
