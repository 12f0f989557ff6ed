// Admission (server/replication/admission.h) on its own: the handshake pools and session slots,
// the access tokens, and each client's allowance of requests, Deforms and stamp cost, on a
// made-up clock.
#include "server/replication/admission.h"

#include <gtest/gtest.h>

namespace loam::server {
namespace {

using namespace std::chrono_literals;

const CoreTime kAdmissionStart = CoreTime{} + 100s;

wire::AccessToken token(uint8_t b) {
  wire::AccessToken t{};
  t.fill(b);
  return t;
}

TEST(Admission, HandshakePoolsRefusePastTheirBoundsAndALeaverFreesItsSlot) {
  ServerConfig c;
  c.max_handshakes = 3;
  c.max_handshakes_per_address = 2;
  Admission a(c, {});
  EXPECT_FALSE(a.connect("10.0.0.1", kAdmissionStart).refused);
  EXPECT_FALSE(a.connect("10.0.0.1", kAdmissionStart).refused);
  // A third from the same address: over the per-address pool, though the whole pool has room.
  const auto third = a.connect("10.0.0.1", kAdmissionStart);
  ASSERT_TRUE(third.refused);
  EXPECT_EQ(third.refused->code, wire::WireErrorCode::kServerFull);
  EXPECT_EQ(third.refused->text, "too many connections in their handshake from 10.0.0.1 (2)");
  a.leave("10.0.0.1", false);
  EXPECT_EQ(a.handshakes(), 2u);
  EXPECT_EQ(a.handshakes_from("10.0.0.1"), 2u);
  EXPECT_FALSE(a.connect("10.0.0.2", kAdmissionStart).refused);
  const auto fourth = a.connect("10.0.0.3", kAdmissionStart);
  ASSERT_TRUE(fourth.refused);
  EXPECT_EQ(fourth.refused->text, "too many connections in their handshake (3)");
  a.leave("10.0.0.3", false);
  a.leave("10.0.0.2", false);
  a.leave("10.0.0.1", false);
  a.leave("10.0.0.1", false);
  EXPECT_EQ(a.handshakes(), 0u);
  EXPECT_EQ(a.handshakes_from("10.0.0.1"), 0u);
}

TEST(Admission, AHelloTradesItsHandshakeSlotForASessionUpToMaxClients) {
  ServerConfig c;
  c.max_clients = 1;
  Admission a(c, {});
  a.connect("10.0.0.1", kAdmissionStart);
  a.connect("10.0.0.2", kAdmissionStart);
  const auto first = a.enter_session("10.0.0.1", std::nullopt, wire::Role::kPlayer);
  ASSERT_TRUE(std::holds_alternative<wire::Role>(first));
  EXPECT_EQ(std::get<wire::Role>(first), wire::Role::kPlayer);
  EXPECT_EQ(a.sessions(), 1u);
  EXPECT_EQ(a.handshakes(), 1u);
  const auto second = a.enter_session("10.0.0.2", std::nullopt, wire::Role::kPlayer);
  ASSERT_TRUE(std::holds_alternative<Refusal>(second));
  EXPECT_EQ(std::get<Refusal>(second).code, wire::WireErrorCode::kServerFull);
  EXPECT_EQ(std::get<Refusal>(second).text, "server full (1 clients)");
  // Refused, it keeps its handshake slot until it leaves.
  EXPECT_EQ(a.handshakes(), 1u);
  a.leave("10.0.0.2", false);
  a.leave("10.0.0.1", true);
  EXPECT_EQ(a.sessions(), 0u);
  EXPECT_EQ(a.handshakes(), 0u);
}

TEST(Admission, TokensGrantTheRoleAskedForOrSpectatorAndAWrongOneIsRefused) {
  AccessTokens tokens;
  tokens.editors = {token(1)};
  tokens.viewers = {token(2)};
  Admission a(ServerConfig{}, tokens);
  for (int i = 0; i < 4; ++i) a.connect("h", kAdmissionStart);
  EXPECT_EQ(std::get<wire::Role>(a.enter_session("h", token(1), wire::Role::kPlayer)), wire::Role::kPlayer);
  EXPECT_EQ(std::get<wire::Role>(a.enter_session("h", token(2), wire::Role::kPlayer)),
            wire::Role::kSpectator);
  const auto wrong = a.enter_session("h", token(3), wire::Role::kPlayer);
  ASSERT_TRUE(std::holds_alternative<Refusal>(wrong));
  EXPECT_EQ(std::get<Refusal>(wrong).code, wire::WireErrorCode::kUnauthorized);
  EXPECT_EQ(std::get<Refusal>(wrong).text, "wrong access token");
  const auto none = a.enter_session("h", std::nullopt, wire::Role::kPlayer);
  ASSERT_TRUE(std::holds_alternative<Refusal>(none));
  EXPECT_EQ(std::get<Refusal>(none).text, "this server requires an access token");
  EXPECT_EQ(a.sessions(), 2u);
  // New tokens take effect for the next Hello.
  a.set_access({});
  EXPECT_EQ(std::get<wire::Role>(a.enter_session("h", std::nullopt, wire::Role::kPlayer)),
            wire::Role::kPlayer);
}

TEST(Admission, RequestsPastTheirRateAreRefusedAndOnlyTheFirstOfARunIsAnswered) {
  ServerConfig c;
  c.requests_per_second = 2;
  c.request_burst = 2;
  Admission a(c, {});
  ClientAllowance al = a.connect("h", kAdmissionStart).allowance;
  EXPECT_TRUE(a.admit_request(al, wire::MessageType::kPing, kAdmissionStart).admitted);
  EXPECT_TRUE(a.admit_request(al, wire::MessageType::kSubscribe, kAdmissionStart).admitted);
  const auto first = a.admit_request(al, wire::MessageType::kStatsRequest, kAdmissionStart);
  EXPECT_FALSE(first.admitted);
  ASSERT_TRUE(first.answer);
  EXPECT_EQ(first.answer->code, wire::WireErrorCode::kRateLimited);
  EXPECT_EQ(first.answer->field, "requests.rate");
  EXPECT_EQ(first.answer->text, "StatsRequest refused: over 2 requests a second");
  const auto again = a.admit_request(al, wire::MessageType::kPing, kAdmissionStart + 100ms);
  EXPECT_FALSE(again.admitted);
  EXPECT_FALSE(again.answer) << "a flood must not be answered with a flood";
  // Reads pause until the bucket holds a token: half a second at 2 a second.
  EXPECT_EQ(a.reads_paused_until(al, kAdmissionStart + 100ms), kAdmissionStart + 500ms);
  EXPECT_TRUE(a.admit_request(al, wire::MessageType::kPing, kAdmissionStart + 500ms).admitted);
  EXPECT_FALSE(a.reads_paused_until(al, kAdmissionStart + 500ms));
  // Hello, Bye and Deform take no request token.
  for (int i = 0; i < 10; ++i) {
    EXPECT_TRUE(a.admit_request(al, wire::MessageType::kDeform, kAdmissionStart + 500ms).admitted);
    EXPECT_TRUE(a.admit_request(al, wire::MessageType::kHello, kAdmissionStart + 500ms).admitted);
  }
}

TEST(Admission, ADeformIsRefusedOverItsRateOrPastThePendingCapBeforeItsStampIsRead) {
  ServerConfig c;
  c.deforms_per_second = 1;
  c.deform_burst = 2;
  c.max_pending_deforms = 3;
  Admission a(c, {});
  ClientAllowance al = a.connect("h", kAdmissionStart).allowance;
  EXPECT_FALSE(a.check_deform(al, kAdmissionStart));
  Admission::admit(al, 10);
  Admission::admit(al, 10);
  const auto rate = a.check_deform(al, kAdmissionStart);
  ASSERT_TRUE(rate);
  EXPECT_EQ(rate->code, wire::WireErrorCode::kRateLimited);
  EXPECT_EQ(rate->text, "rate limit exceeded");
  // A second later one more may go; then three wait for acks, the cap.
  EXPECT_FALSE(a.check_deform(al, kAdmissionStart + 1s));
  Admission::admit(al, 10);
  const auto pending = a.check_deform(al, kAdmissionStart + 10s);
  ASSERT_TRUE(pending);
  EXPECT_EQ(pending->code, wire::WireErrorCode::kTooManyPending);
  EXPECT_EQ(pending->text, "too many unacknowledged deforms (3)");
  Admission::acknowledged(al);
  EXPECT_FALSE(a.check_deform(al, kAdmissionStart + 10s));
  EXPECT_EQ(al.unacked, 2u);
}

TEST(Admission, AStampOverTheCostCapIsOversizeAndOverWhatIsLeftIsRateLimited) {
  ServerConfig c;
  c.max_stamp_cost = 1000;
  c.stamp_cost_per_second = 500;
  Admission a(c, {});
  ClientAllowance al = a.connect("h", kAdmissionStart).allowance;
  const auto big = a.check_cost(al, 1001);
  ASSERT_TRUE(big);
  EXPECT_EQ(big->code, wire::WireErrorCode::kOversize);
  EXPECT_EQ(big->field, "stamp.cost");
  // The bucket holds the larger of the rate and the cap: one stamp at the cap fits.
  EXPECT_FALSE(a.check_cost(al, 1000));
  Admission::admit(al, 1000);
  const auto spent = a.check_cost(al, 1);
  ASSERT_TRUE(spent);
  EXPECT_EQ(spent->code, wire::WireErrorCode::kRateLimited);
  EXPECT_EQ(spent->text, "the stamp costs 1 sample updates, over what is left of this client's 500 a second");
  // Refilled by check_deform's clock: a second later, 500 more.
  EXPECT_FALSE(a.check_deform(al, kAdmissionStart + 1s));
  EXPECT_FALSE(a.check_cost(al, 500));
  EXPECT_TRUE(a.check_cost(al, 501));
}

TEST(Admission, APeerLosesItsPortButKeepsAnIpv6Address) {
  EXPECT_EQ(address_of("1.2.3.4:5678"), "1.2.3.4");
  EXPECT_EQ(address_of("::1:5678"), "::1");
  EXPECT_EQ(address_of("local"), "local");
}

}  // namespace
}  // namespace loam::server
