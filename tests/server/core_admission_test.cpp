// Admission (server/replication/core_admission.cpp): the handshake pools, request and deform
// rates, stamp cost, the pending cap, exactly once across a reconnect.
#include "tests/server/core_harness.h"

namespace loam::server {
namespace {

using namespace std::chrono_literals;
using core_test::CoreHarness;
using core_test::encoding_of;
using core_test::Received;

TEST(ReplicationCore, UnacknowledgedDeformsAreCappedPerClientNotPerTick) {
  ServerConfig config;
  config.max_pending_deforms = 3;
  CoreHarness h(config);
  const ClientId a = h.join("a");
  for (uint32_t i = 1; i <= 4; ++i) h.send(a, wire::Deform{i, h.stamp(StampKind::kGaussian, 100, 100, 5)});
  auto acks = h.of(a).all<wire::DeformAck>();
  ASSERT_EQ(acks.size(), 1u);  // the fourth, refused at once
  EXPECT_FALSE(acks[0].accepted);
  EXPECT_EQ(acks[0].client_seq, 4u);
  EXPECT_EQ(acks[0].reject_code, wire::WireErrorCode::kTooManyPending);
  h.tick();  // the three are acknowledged: room again
  h.send(a, wire::Deform{5, h.stamp(StampKind::kGaussian, 100, 100, 5)});
  acks = h.of(a).all<wire::DeformAck>();
  ASSERT_EQ(acks.size(), 4u);
  for (size_t i = 1; i < 4; ++i) EXPECT_TRUE(acks[i].accepted);
  h.tick();
  EXPECT_EQ(h.of(a).all<wire::DeformAck>().size(), 5u);
  EXPECT_TRUE(h.of(a).all<wire::DeformAck>().back().accepted);
}

TEST(ReplicationCore, RequestsOverTheClientsRateAreDroppedWithOneErrorPerRun) {
  ServerConfig config;
  config.requests_per_second = 10;
  config.request_burst = 5;
  CoreHarness h(config);
  const ClientId a = h.join("a"), b = h.join("b");
  for (uint64_t i = 0; i < 20; ++i) h.send(a, wire::Ping{i});
  EXPECT_EQ(h.of(a).all<wire::Pong>().size(), 5u);
  auto errors = h.of(a).all<wire::ErrorMsg>();
  ASSERT_EQ(errors.size(), 1u);  // not one per refused request
  EXPECT_EQ(errors[0].code, wire::WireErrorCode::kRateLimited);
  EXPECT_EQ(h.core().stats().requests_refused, 15u);
  // Another client is not affected; the first gets its rate back as time passes.
  h.send(b, wire::Ping{1});
  EXPECT_EQ(h.of(b).all<wire::Pong>().size(), 1u);
  h.tick(300ms);
  for (uint64_t i = 0; i < 3; ++i) h.send(a, wire::Ping{100 + i});
  EXPECT_EQ(h.of(a).all<wire::Pong>().size(), 8u);
  EXPECT_EQ(h.of(a).all<wire::ErrorMsg>().size(), 1u);
  // Subscriptions draw on the same bucket.
  for (int i = 0; i < 10; ++i) h.send(a, h.subscribe_all(true));
  EXPECT_EQ(h.of(a).all<wire::ErrorMsg>().size(), 2u);
}

// Once a client has had a request refused for its rate, the transport stops reading it until
// its bucket holds a token again: a flood then waits in the flooder's socket instead of being
// decoded and dropped here. Other clients are never paused.
TEST(ReplicationCore, AClientOverItsRequestRateIsReadAgainWhenItsBucketRefills) {
  ServerConfig config;
  config.requests_per_second = 10;
  config.request_burst = 5;
  CoreHarness h(config);
  const ClientId a = h.join("a"), b = h.join("b");
  EXPECT_EQ(h.core().reads_paused_until(a, h.now()), std::nullopt);
  for (uint64_t i = 0; i < 5; ++i) h.send(a, wire::Ping{i});
  // The burst spent, but nothing refused yet: still read (the next request earns the Error).
  EXPECT_EQ(h.core().reads_paused_until(a, h.now()), std::nullopt);
  h.send(a, wire::Ping{5});
  ASSERT_EQ(h.of(a).all<wire::ErrorMsg>().size(), 1u);
  const auto until = h.core().reads_paused_until(a, h.now());
  ASSERT_TRUE(until.has_value());
  EXPECT_GT(*until, h.now());
  EXPECT_LE(*until, h.now() + 100ms);  // one token at 10 a second
  EXPECT_EQ(h.core().reads_paused_until(b, h.now()), std::nullopt);
  EXPECT_EQ(h.core().reads_paused_until(a, *until), std::nullopt);
  h.tick(100ms);
  h.send(a, wire::Ping{6});
  EXPECT_EQ(h.of(a).all<wire::Pong>().size(), 6u);
  EXPECT_EQ(h.core().reads_paused_until(a, h.now()), std::nullopt);  // admitted: no longer refused
}

TEST(ReplicationCore, StampsAreAdmittedByCostPerStampAndPerClient) {
  CoreHarness probe;  // the stamps' costs, to size the limits
  const WorldParams& p = probe.core().terrain().world().params();
  const QuantizedStamp wide = probe.stamp(StampKind::kGaussian, 300, 300, 60);
  const uint64_t wide_cost = *stamp_cost(wide, p);
  // A shockwave of many steps over a wide box.
  StampParams s;
  s.kind = StampKind::kShockwave;
  s.center_x = s.center_y = 400;
  s.radius = 20;
  s.intensity = 1;
  s.steps = 200;
  s.speed = 0.5;
  auto wave = validate_stamp(s, p, probe.core().terrain().limits());
  ASSERT_TRUE(wave.ok()) << wave.error().describe();
  const uint64_t wave_cost = *stamp_cost(*wave, p);
  ServerConfig config;
  config.max_stamp_cost = 10 * wide_cost;
  config.stamp_cost_per_second = wide_cost;  // a burst of ten, then one a second
  ASSERT_GT(wave_cost, config.max_stamp_cost);
  CoreHarness h(config);
  const ClientId heavy = h.join("heavy"), light = h.join("light");
  h.send(heavy, wire::Deform{1, *wave});
  for (uint32_t i = 0; i < 12; ++i) h.send(heavy, wire::Deform{2 + i, wide});
  // The light client's small stamps go through meanwhile: a bucket of its own.
  for (uint32_t i = 1; i <= 5; ++i) h.send(light, wire::Deform{i, h.stamp(StampKind::kCrater, 100, 100, 5)});
  h.tick();
  h.tick();
  size_t accepted = 0, over_limit = 0, over_budget = 0;
  for (const auto& a : h.of(heavy).all<wire::DeformAck>()) {
    accepted += a.accepted;
    if (!a.accepted && a.field == "stamp.cost") {
      over_limit += a.reject_code == wire::WireErrorCode::kOversize;
      over_budget += a.reject_code == wire::WireErrorCode::kRateLimited;
    }
  }
  EXPECT_EQ(over_limit, 1u);  // the shockwave
  EXPECT_EQ(accepted, 10u);
  EXPECT_EQ(over_budget, 2u);
  const auto light_acks = h.of(light).all<wire::DeformAck>();
  EXPECT_EQ(light_acks.size(), 5u);
  for (const auto& a : light_acks) EXPECT_TRUE(a.accepted);
}

TEST(ReplicationCore, DeformsResentAfterAReconnectAreAnsweredOnceAndAppliedOnce) {
  CoreHarness h;
  const auto hello = [&](ClientId id, const std::string& name, uint64_t key) {
    wire::Hello m;
    m.client_name = name;
    m.resume_key = key;
    h.send(id, m);
  };
  const QuantizedStamp s1 = h.stamp(StampKind::kCrater, 100, 100, 8),
                       s2 = h.stamp(StampKind::kGaussian, 200, 100, 8),
                       s3 = h.stamp(StampKind::kCrater, 300, 100, 8);
  const ClientId a = h.core().connect("test:a", h.now());
  hello(a, "a", 42);
  h.send(a, wire::Deform{1, s1});
  h.send(a, wire::Deform{2, s2});
  h.tick();  // both committed; a has their answers
  ASSERT_EQ(h.of(a).all<wire::DeformAck>().size(), 2u);
  const uint64_t seq2 = h.of(a).all<wire::DeformAck>()[1].global_seq;
  h.send(a, wire::Deform{3, s3});         // admitted, waiting for its tick...
  h.core().disconnected(a, "link lost");  // ...when the link goes
  // The client comes back with the same key and sends again what it never saw answered (and
  // one it did: its answer was lost on the way, say).
  const ClientId b = h.core().connect("test:b", h.now());
  hello(b, "a", 42);
  // The server still knows the key: resending is safe (after a restart it would say not).
  ASSERT_EQ(h.of(b).all<wire::Welcome>().size(), 1u);
  EXPECT_TRUE(h.of(b).all<wire::Welcome>()[0].resume_key_known);
  EXPECT_FALSE(h.of(a).all<wire::Welcome>()[0].resume_key_known);  // a new key at first
  h.send(b, wire::Deform{2, s2});
  h.send(b, wire::Deform{3, s3});
  const auto now_acks = h.of(b).all<wire::DeformAck>();
  ASSERT_EQ(now_acks.size(), 1u);  // 2: its first answer again, at once
  EXPECT_EQ(now_acks[0].client_seq, 2u);
  EXPECT_TRUE(now_acks[0].accepted);
  EXPECT_EQ(now_acks[0].global_seq, seq2);
  h.tick();  // 3 commits once, answered on the new connection
  const auto acks = h.of(b).all<wire::DeformAck>();
  ASSERT_EQ(acks.size(), 2u);
  EXPECT_EQ(acks[1].client_seq, 3u);
  EXPECT_TRUE(acks[1].accepted);
  EXPECT_EQ(acks[1].global_seq, 3u);
  EXPECT_EQ(h.core().terrain().last_seq(), 3u);  // three stamps, none twice
  EXPECT_EQ(h.core().stats().deforms_resent, 2u);
  // Another key's sequence numbers are its own; no key, no memory.
  const ClientId c = h.core().connect("test:c", h.now());
  hello(c, "c", 7);
  h.send(c, wire::Deform{2, s2});
  const ClientId d = h.join("d");
  h.send(d, wire::Deform{2, s2});
  h.send(d, wire::Deform{2, s2});
  h.tick();
  EXPECT_EQ(h.core().terrain().last_seq(), 6u);
}

TEST(ReplicationCore, ConnectionsInTheirHandshakeHaveAPoolOfTheirOwnPerAddress) {
  ServerConfig config;
  config.max_clients = 2;
  config.max_handshakes = 3;
  config.max_handshakes_per_address = 2;
  CoreHarness h(config);
  const CoreTime t = h.now();
  const ClientId x1 = h.core().connect("10.0.0.1:1001", t), x2 = h.core().connect("10.0.0.1:1002", t);
  const ClientId x3 = h.core().connect("10.0.0.1:1003", t);  // a third from the same address
  EXPECT_TRUE(h.core().in_handshake(x1));
  EXPECT_TRUE(h.core().in_handshake(x2));
  EXPECT_FALSE(h.core().in_handshake(x3));  // refused and closed
  const ClientId y1 = h.core().connect("10.0.0.2:2001", t);
  const ClientId z1 = h.core().connect("10.0.0.3:3001", t);  // the pool of three is full
  EXPECT_TRUE(h.core().in_handshake(y1));
  EXPECT_FALSE(h.core().in_handshake(z1));
  // Leaving the handshake frees a place: in session now, not in the pool.
  wire::Hello hello;
  hello.client_name = "x1";
  h.send(x1, hello);
  ASSERT_EQ(h.of(x1).all<wire::Welcome>().size(), 1u);
  const ClientId x4 = h.core().connect("10.0.0.1:1004", t);
  EXPECT_TRUE(h.core().in_handshake(x4));
  // Sessions are counted apart: two in session, the third Hello is refused as full.
  hello.client_name = "x2";
  h.send(x2, hello);
  EXPECT_EQ(h.of(x2).all<wire::Welcome>().size(), 1u);
  hello.client_name = "y1";
  h.send(y1, hello);
  EXPECT_TRUE(h.of(y1).all<wire::Welcome>().empty());
  const auto errors = h.of(y1).all<wire::ErrorMsg>();
  ASSERT_EQ(errors.size(), 1u);
  EXPECT_EQ(errors[0].code, wire::WireErrorCode::kServerFull);
}

}  // namespace
}  // namespace loam::server
