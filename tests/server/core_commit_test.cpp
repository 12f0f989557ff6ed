// The commit pipeline (server/replication/core_commit.cpp): acks before the apply, events after it,
// the apply outlasting a tick, the tick's cost budget.
#include "tests/server/core_harness.h"

namespace loam::server {
namespace {

using namespace std::chrono_literals;
using core_test::CoreHarness;
using core_test::encoding_of;
using core_test::Received;

// A detail-layer shockwave over much of the detail area, 256 steps: far longer to apply than
// a tick.
Result<QuantizedStamp> heavy_detail_shockwave(CoreHarness& h) {
  const WorldParams& w = h.core().terrain().world().params();
  const RectI d = w.detail_sample_rect();
  StampParams heavy;
  heavy.kind = StampKind::kShockwave;
  heavy.layer = Layer::kDetail;
  heavy.center_x = double(d.x0 + d.x1) / 2 * w.detail_meters_per_sample();
  heavy.center_y = double(d.y0 + d.y1) / 2 * w.detail_meters_per_sample();
  heavy.radius = 400 * w.detail_meters_per_sample();
  heavy.intensity = 0.5, heavy.speed = 0.5, heavy.damping = 0.01, heavy.steps = 256;
  return validate_stamp(heavy, w, h.core().terrain().limits());
}

TEST(ReplicationCore, ClientsInSyncAtEveryMipGetTheEventAndNoRegionForPerSampleStamps) {
  CoreHarness h;
  const auto [a, b] = h.two_players_in_sync();
  const StampKind kinds[] = {StampKind::kGaussian, StampKind::kCrater, StampKind::kFootprint,
                             StampKind::kFlatten};
  uint32_t seq = 0;
  for (const StampKind k : kinds) {
    // At a four-tile corner, so mip-0 and coarser tiles all change.
    h.send(a, wire::Deform{++seq, h.stamp(k, 256.0, 256.0, 30.0)});
  }
  h.tick();
  for (const ClientId id : {a, b}) {
    EXPECT_EQ(h.of(id).all<wire::DeformEvent>().size(), 4u);
    EXPECT_TRUE(h.of(id).all<wire::RegionUpdate>().empty()) << "client " << id;
    EXPECT_EQ(h.core().tiles_of(id)->due_count(), 0u);
  }
  const auto acks = h.of(a).all<wire::DeformAck>();
  ASSERT_EQ(acks.size(), 4u);
  for (const auto& ack : acks) EXPECT_TRUE(ack.accepted);
  // Each event is a handful of bytes per changed tile.
  EXPECT_LT(h.of(b).event_bytes / 4, 100u);
}

TEST(ReplicationCore, ATicksAcksLeaveBeforeItsStampsAreAppliedAndEventsAfter) {
  CoreHarness h;
  const auto [a, b] = h.two_players_in_sync();
  // A costly shockwave from one client and a small crater from the other, in one tick.
  h.send(a, wire::Deform{1, h.stamp(StampKind::kShockwave, 300.0, 200.0, 40.0)});
  h.send(b, wire::Deform{1, h.stamp(StampKind::kCrater, 100.0, 100.0, 5.0)});
  const auto early = h.tick_with_early_acks();
  EXPECT_EQ(early.applied_seq, 0u) << "nothing applied when the acks are handed over";
  const auto acks = early.acks.all<wire::DeformAck>();
  ASSERT_EQ(acks.size(), 2u);
  EXPECT_TRUE(acks[0].accepted && acks[1].accepted);
  EXPECT_EQ(acks[0].global_seq, 1u);
  EXPECT_EQ(acks[1].global_seq, 2u);
  EXPECT_TRUE(early.acks.all<wire::DeformEvent>().empty());
  // The events follow once applied, at the sequence the acks promised.
  EXPECT_EQ(h.core().terrain().last_seq(), 2u);
  for (const ClientId id : {a, b}) {
    const auto events = h.of(id).all<wire::DeformEvent>();
    ASSERT_EQ(events.size(), 2u) << "client " << id;
    EXPECT_EQ(events[0].global_seq, 1u);
    EXPECT_EQ(events[1].global_seq, 2u);
    EXPECT_TRUE(h.of(id).all<wire::DeformAck>().empty());
  }
}

TEST(ReplicationCore, AStampStillApplyingHoldsNoAckOfTheNextTickAndEventsFollowInOrder) {
  ServerConfig config;
  config.apply_wait_ms = 0;  // a tick never waits for the apply
  config.max_stamp_cost = config.stamp_cost_per_second = 1ull << 40;
  CoreHarness h(config);
  const auto [a, b] = h.two_players_in_sync();
  // A detail-layer shockwave over much of the detail area, 256 steps: far longer to
  // apply than a tick.
  const auto q = heavy_detail_shockwave(h);
  ASSERT_TRUE(q.ok()) << q.error().describe();
  h.send(a, wire::Deform{1, *q});
  h.tick();
  ASSERT_EQ(h.of(a).all<wire::DeformAck>().size(), 1u);
  EXPECT_EQ(h.of(a).all<wire::DeformAck>()[0].global_seq, 1u);
  EXPECT_EQ(h.core().sequenced_seq(), 1u);
  EXPECT_EQ(h.core().published_seq(), 0u) << "the shockwave is still being applied";
  // The next tick: b's crater is sequenced and acknowledged while the shockwave runs, and a
  // client joining now continues from what was published.
  h.send(b, wire::Deform{1, h.stamp(StampKind::kCrater, 100.0, 100.0, 5.0)});
  h.tick();
  ASSERT_EQ(h.of(b).all<wire::DeformAck>().size(), 1u);
  EXPECT_EQ(h.of(b).all<wire::DeformAck>()[0].global_seq, 2u);
  const ClientId late = h.join("late");
  const auto welcome = h.of(late).all<wire::Welcome>();
  ASSERT_EQ(welcome.size(), 1u);
  EXPECT_EQ(welcome[0].global_sequence, h.core().published_seq());
  h.finish_applying();
  EXPECT_EQ(h.core().terrain().last_seq(), 2u);
  EXPECT_EQ(h.core().published_seq(), 2u);
  // The players hold coarse tiles only: the detail shockwave sends them nothing, the crater
  // its event, once the shockwave before it is applied.
  for (const ClientId id : {a, b}) {
    const auto events = h.of(id).all<wire::DeformEvent>();
    ASSERT_EQ(events.size(), 1u) << "client " << id;
    EXPECT_EQ(events[0].global_seq, 2u);
  }
}

// The core reads no clock and never blocks: a tick whose apply is still running says what it
// waits for (applying()), streams nothing, and the caller's wait decides when it goes on.
TEST(ReplicationCore, ATickWaitingForItsApplyNamesTheWorkerAndStreamsOnlyOnceTheCallerHasWaited) {
  ServerConfig config;
  config.apply_wait_ms = 0;
  config.max_stamp_cost = config.stamp_cost_per_second = 1ull << 40;
  CoreHarness h(config);
  const auto [a, b] = h.two_players_in_sync();
  // A detail-layer shockwave over much of the detail area, 256 steps: far longer to
  // apply than a tick.
  const auto q = heavy_detail_shockwave(h);
  ASSERT_TRUE(q.ok()) << q.error().describe();
  h.send(a, wire::Deform{1, *q});
  TickHooks hooks;
  ApplyWorker* waited_on = nullptr;
  hooks.wait_for_apply = [&](ApplyWorker& worker) {
    waited_on = &worker;
    return false;  // the caller's deadline has passed: go on without the apply
  };
  const bool streamed = run_tick(h.core(), h.now() + 33ms, 0, hooks);
  // The tick streams exactly when it did not have to wait (a worker far quicker than usual).
  EXPECT_EQ(streamed, waited_on == nullptr);
  if (waited_on != nullptr) {
    EXPECT_EQ(waited_on, h.core().applying());
    EXPECT_EQ(h.core().published_seq(), 0u);
    waited_on->wait();
  }
  EXPECT_TRUE(h.core().advance_apply());
  EXPECT_EQ(h.core().applying(), nullptr);
  EXPECT_EQ(h.core().published_seq(), 1u);
  EXPECT_EQ(h.core().sequenced_seq(), 1u);
}

TEST(ReplicationCore, ATickAppliesStampsUpToItsCostBudgetAndTheRestFollowInOrder) {
  ServerConfig config;
  CoreHarness probe;  // the stamps' cost, to size the budget
  const QuantizedStamp q = probe.stamp(StampKind::kGaussian, 300, 300, 40);
  const uint64_t cost = *stamp_cost(q, probe.core().terrain().world().params());
  config.tick_stamp_cost = 2 * cost;
  CoreHarness h(config);
  const ClientId a = h.join("a");
  for (uint32_t i = 1; i <= 5; ++i) h.send(a, wire::Deform{i, q});
  h.tick();
  EXPECT_EQ(h.of(a).all<wire::DeformAck>().size(), 2u);
  h.tick();
  EXPECT_EQ(h.of(a).all<wire::DeformAck>().size(), 4u);
  h.tick();
  const auto acks = h.of(a).all<wire::DeformAck>();
  ASSERT_EQ(acks.size(), 5u);
  for (uint32_t i = 0; i < 5; ++i) {
    EXPECT_TRUE(acks[i].accepted);
    EXPECT_EQ(acks[i].client_seq, i + 1);  // in order
    if (i > 0) {
      EXPECT_EQ(acks[i].global_seq, acks[i - 1].global_seq + 1);
    }
  }
}

}  // namespace
}  // namespace loam::server
