// Bad input against a live server: each case gets its Error or disconnect, the server stays
// up, and a well-behaved client connected throughout still converges on the server's tiles.
#include <gtest/gtest.h>

#include <cmath>

#include "integration_util.h"
#include "server_process.h"

namespace loam::test {
namespace {

using namespace std::chrono_literals;

constexpr const char* kEditorToken = "00112233445566778899aabbccddeeff";
constexpr const char* kViewerToken = "ffeeddccbbaa99887766554433221100";

wire::AccessToken token(const char* hex) {
  wire::AccessToken t{};
  for (size_t i = 0; i < t.size(); ++i) t[i] = uint8_t(std::stoi(std::string(hex + 2 * i, 2), nullptr, 16));
  return t;
}

// Waits for the server to answer with an Error (returned) and, if `closes`, to close.
std::optional<wire::ErrorMsg> expect_error(client::Connection& c, bool closes) {
  std::optional<wire::ErrorMsg> err;
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (std::chrono::steady_clock::now() < deadline) {
    auto m = c.next(100ms);
    if (!m) return closes ? err : std::nullopt;  // closed
    if (!m->has_value()) {
      if (err && !closes) return err;
      continue;
    }
    if (auto* e = std::get_if<wire::ErrorMsg>(&**m)) err = *e;
  }
  return closes ? std::nullopt : err;  // a close was expected but never came
}

// Deforms next_seq + 1 ... next_seq + n as raw frames in one write, past the client library's
// pacing; returns their client sequence numbers.
std::vector<uint32_t> send_raw_deforms(client::TerrainClient& c, StampRng& rng, uint32_t& next_seq, int n) {
  std::vector<uint32_t> seqs;
  std::vector<uint8_t> bytes;
  for (int i = 0; i < n; ++i) {
    const auto frame = wire::encode_frame(wire::Deform{++next_seq, random_stamp(rng, c.welcome().world)});
    EXPECT_TRUE(frame.ok());
    if (frame.ok()) bytes.insert(bytes.end(), frame->begin(), frame->end());
    seqs.push_back(next_seq);
  }
  c.connection().send_raw(std::move(bytes));
  return seqs;
}

// Pumps until every one of `seqs` has its DeformAck.
bool all_answered(client::TerrainClient& c, const std::vector<uint32_t>& seqs) {
  return c.wait_until(
      [&] {
        for (uint32_t s : seqs)
          if (!c.ack(s)) return false;
        return true;
      },
      20s);
}

class BadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = temp_data_dir("bad");
    ASSERT_TRUE(server_.start(
        dir_, {"--tick-hz", "60", "--editor-token", kEditorToken, "--viewer-token", kViewerToken,
               "--deforms-per-second", "20", "--deform-burst", "10", "--max-queue-bytes", "4000000"}))
        << server_.log();
    ASSERT_TRUE(
        good_.connect("127.0.0.1", server_.port(), "good", wire::Role::kPlayer, token(kEditorToken)).ok());
    ASSERT_TRUE(good_.subscribe(good_.all_coarse_tiles(0)).ok());
  }
  void TearDown() override {
    // The server is still up and the good client still converges after a few stamps.
    StampRng rng(77);
    uint32_t last = 0;
    for (int i = 0; i < 5; ++i) last = *good_.deform(random_stamp(rng, good_.welcome().world));
    ASSERT_TRUE(good_.wait_until([&] { return good_.ack(last).has_value(); }, 30s)) << server_.log();
    ASSERT_TRUE(good_.ack(last)->accepted);
    const World expected = replayed_world(dir_, good_.ack(last)->global_seq);
    EXPECT_TRUE(good_.wait_until([&] { return bool(store_matches(good_, expected)); }, 30s))
        << store_matches(good_, expected).message();
    EXPECT_EQ(server_.terminate(), 0) << server_.log();
  }
  client::Connection& raw_connect() {
    raw_ = std::make_unique<client::Connection>();
    wire::Hello h;
    h.client_name = "raw";
    h.access_token = token(kEditorToken);
    EXPECT_TRUE(raw_->connect("127.0.0.1", server_.port(), h).ok());
    return *raw_;
  }

  std::string dir_;
  ServerProcess server_;
  client::TerrainClient good_;
  std::unique_ptr<client::Connection> raw_;
};

TEST_F(BadInput, GarbageBytesGetAnErrorAndAClose) {
  auto& c = raw_connect();
  std::vector<uint8_t> junk(64);
  for (size_t i = 0; i < junk.size(); ++i) junk[i] = uint8_t(i * 37 + 11);
  c.send_raw(junk);
  const auto err = expect_error(c, true);
  ASSERT_TRUE(err.has_value());
}

TEST_F(BadInput, OversizeFrameLengthIsRejectedBeforeAllocation) {
  auto& c = raw_connect();
  // Header claiming a 1 GiB Ping payload.
  c.send_raw({0x00, 0x00, 0x00, 0x40, 0x04, 0x00});
  const auto err = expect_error(c, true);
  ASSERT_TRUE(err.has_value());
  EXPECT_EQ(err->code, wire::WireErrorCode::kOversize);
}

TEST_F(BadInput, TruncatedFrameThenHangUpDisturbsNobody) {
  auto& c = raw_connect();
  auto frame = wire::encode_frame(wire::Ping{42});
  ASSERT_TRUE(frame.ok());
  frame->erase(frame->end() - 3,
               frame->end());  // resize() here trips a GCC 12 -Wstringop-overflow false positive
  c.send_raw(*frame);
  c.close();
}

TEST_F(BadInput, WrongProtocolVersionIsNamedInTheError) {
  client::Connection c;
  wire::Hello h;
  h.version_major = 9;
  h.access_token = token(kEditorToken);
  auto w = c.connect("127.0.0.1", server_.port(), h);
  ASSERT_FALSE(w.ok());
  EXPECT_NE(w.error().describe().find("9.0"), std::string::npos) << w.error().describe();
  const std::string ours = std::to_string(wire::kProtocolMajor) + "." + std::to_string(wire::kProtocolMinor);
  EXPECT_NE(w.error().describe().find(ours), std::string::npos) << w.error().describe();
}

TEST_F(BadInput, MissingOrWrongTokenIsRefused) {
  client::TerrainClient none;
  const Status st = none.connect("127.0.0.1", server_.port(), "anon");
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kUnauthorized) << st.error().describe();
  client::TerrainClient wrong;
  const Status st2 = wrong.connect("127.0.0.1", server_.port(), "wrong", wire::Role::kPlayer,
                                   token("0123456789abcdef0123456789abcdef"));
  ASSERT_FALSE(st2.ok());
  EXPECT_EQ(st2.error().code, ErrorCode::kUnauthorized);
}

TEST_F(BadInput, ViewerDeformIsRejectedAndTheConnectionStays) {
  client::TerrainClient viewer;
  ASSERT_TRUE(
      viewer.connect("127.0.0.1", server_.port(), "viewer", wire::Role::kPlayer, token(kViewerToken)).ok());
  EXPECT_EQ(viewer.welcome().granted_role, wire::Role::kSpectator);
  StampRng rng(1);
  const uint32_t s = *viewer.deform(random_stamp(rng, viewer.welcome().world));
  ASSERT_TRUE(viewer.wait_until([&] { return viewer.ack(s).has_value(); }, 10s));
  EXPECT_FALSE(viewer.ack(s)->accepted);
  EXPECT_EQ(viewer.ack(s)->code, wire::WireErrorCode::kUnauthorized);
  // Still connected: subscriptions work.
  ASSERT_TRUE(viewer.subscribe({{Layer::kCoarse, 0, 0, 0}}).ok());
  EXPECT_TRUE(viewer.wait_until(
      [&] {
        return viewer.store().version({Layer::kCoarse, 0, 0, 0}).has_value();
      },
      10s));
}

TEST_F(BadInput, NonFiniteAndOutOfRangeStampsAreRejectedNamingTheField) {
  // NaN never reaches the wire: validation names the field on the client side.
  StampParams p;
  p.center_x = 100;
  p.center_y = 100;
  p.radius = std::nan("");
  auto q = validate_stamp(p, good_.welcome().world);
  ASSERT_FALSE(q.ok());
  EXPECT_EQ(q.error().code, ErrorCode::kNotFinite);
  EXPECT_NE(q.error().field.find("radius"), std::string::npos);
  // A quantized stamp crafted past validation: radius 0, then an unknown texture id.
  StampRng rng(2);
  // Each crafted stamp is a plain gaussian apart from its one bad field, so the server has no
  // other field to name first.
  auto plain_gaussian = [&] {
    QuantizedStamp g = random_stamp(rng, good_.welcome().world);
    g.kind = StampKind::kGaussian;
    g.blend = BlendMode::kAdd;
    g.flags = 0;
    g.shape = g.damping = g.speed = g.steps = 0;
    g.target = 0;
    return g;
  };
  QuantizedStamp bad = plain_gaussian();
  bad.radius = 0;
  client::TerrainClient c;
  ASSERT_TRUE(
      c.connect("127.0.0.1", server_.port(), "crafty", wire::Role::kPlayer, token(kEditorToken)).ok());
  const uint32_t s1 = *c.deform(bad);
  QuantizedStamp tex = plain_gaussian();
  tex.kind = StampKind::kTexture;
  tex.texture_id = 0x1234567890abcdefull;
  const uint32_t s2 = *c.deform(tex);
  ASSERT_TRUE(c.wait_until([&] { return c.ack(s1) && c.ack(s2); }, 10s));
  EXPECT_FALSE(c.ack(s1)->accepted);
  EXPECT_NE(c.ack(s1)->field.find("radius"), std::string::npos) << c.ack(s1)->field;
  EXPECT_FALSE(c.ack(s2)->accepted);
  EXPECT_NE(c.ack(s2)->field.find("texture"), std::string::npos) << c.ack(s2)->field;
}

// docs/stamps.md allows a target only on flatten and the min/max blends; a crafted gaussian
// that carries one is refused by the server, naming the field, and the connection stays.
TEST_F(BadInput, GaussianWithTargetIsRejectedNamingTheField) {
  StampRng rng(4);
  QuantizedStamp bad = random_stamp(rng, good_.welcome().world);
  bad.kind = StampKind::kGaussian;
  bad.blend = BlendMode::kAdd;
  bad.flags = 0;
  bad.shape = bad.damping = bad.speed = bad.steps = 0;
  bad.target = 1000;
  client::TerrainClient c;
  ASSERT_TRUE(
      c.connect("127.0.0.1", server_.port(), "targeted", wire::Role::kPlayer, token(kEditorToken)).ok());
  const uint32_t s = *c.deform(bad);
  ASSERT_TRUE(c.wait_until([&] { return c.ack(s).has_value(); }, 10s));
  EXPECT_FALSE(c.ack(s)->accepted);
  EXPECT_NE(c.ack(s)->field.find("target"), std::string::npos) << c.ack(s)->field;
  EXPECT_TRUE(c.connection().open());
}

TEST_F(BadInput, FloodBeyondTheRateLimitIsRejectedWithoutDisconnecting) {
  client::TerrainClient c;
  ASSERT_TRUE(c.connect("127.0.0.1", server_.port(), "flood", wire::Role::kPlayer, token(kEditorToken)).ok());
  // Raw frames, all at once: the client library would pace them to the announced limits.
  StampRng rng(3);
  uint32_t next_seq = 0;
  const std::vector<uint32_t> seqs = send_raw_deforms(c, rng, next_seq, 60);
  ASSERT_TRUE(all_answered(c, seqs));
  int limited = 0, accepted = 0;
  for (uint32_t s : seqs) {
    const auto a = c.ack(s);
    ASSERT_TRUE(a.has_value());
    if (a->accepted) ++accepted;
    if (!a->accepted && a->code == wire::WireErrorCode::kRateLimited) ++limited;
  }
  EXPECT_GT(limited, 0);
  EXPECT_GE(accepted, 10) << "the burst is honoured";
  EXPECT_TRUE(c.connection().open());
}

// The same sixty through the client library: it keeps to the Welcome's limits (20 a
// second here, 64 unacknowledged), so a backlog is accepted in full, in order.
TEST_F(BadInput, ABacklogWithinTheAnnouncedLimitsIsAcceptedInFull) {
  client::TerrainClient c;
  ASSERT_TRUE(
      c.connect("127.0.0.1", server_.port(), "backlog", wire::Role::kPlayer, token(kEditorToken)).ok());
  StampRng rng(3);
  std::vector<uint32_t> seqs;
  for (int i = 0; i < 60; ++i) seqs.push_back(*c.deform(random_stamp(rng, c.welcome().world)));
  EXPECT_GT(c.deforms_queued(), 0u);  // most wait on the client's side
  ASSERT_TRUE(all_answered(c, seqs));
  uint64_t last = 0;
  for (uint32_t s : seqs) {
    const auto a = c.ack(s);
    ASSERT_TRUE(a->accepted) << "deform " << s << ": " << a->field;
    EXPECT_GT(a->global_seq, last);  // in order
    last = a->global_seq;
  }
}

TEST_F(BadInput, ClientThatNeverReadsIsDroppedWithABoundedQueue) {
  client::TerrainClient lazy;
  ASSERT_TRUE(
      lazy.connect("127.0.0.1", server_.port(), "lazy", wire::Role::kPlayer, token(kEditorToken)).ok());
  lazy.connection().pause_reading();
  // Every Subscribe of tiles not held asks for them again, each tick: far more than any socket
  // buffer holds, so the server's queue for this client must hit its bound. Requests are
  // rate-limited (30 a second), so they go over a few seconds, as a real client's would.
  const auto tiles = lazy.all_coarse_tiles(0);
  for (int i = 0; i < 400 && server_.log().find("event=drop") == std::string::npos; ++i) {
    wire::Subscribe sub;
    for (const auto& t : tiles) sub.entries.push_back({t, false, 0});
    ASSERT_TRUE(lazy.connection().send(sub).ok());
    (void)good_.pump(25ms);  // keep the good client's socket drained meanwhile
  }
  EXPECT_TRUE(good_.wait_until([&] { return server_.log().find("event=drop") != std::string::npos; }, 30s))
      << server_.log();
}

TEST(ServerFull, AFullServerRefusesAsBusyNotUnauthorized) {
  const std::string dir = temp_data_dir("full");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--max-clients", "1"})) << server.log();
  client::TerrainClient first;
  ASSERT_TRUE(first.connect("127.0.0.1", server.port(), "first").ok());
  client::TerrainClient second;
  const Status st = second.connect("127.0.0.1", server.port(), "second");
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kBusy) << st.error().describe();
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

// Welcome's limits.max_pending_deforms promises a count of Deforms queued and not yet
// acknowledged. The server once counted Deforms per tick instead; this pins the promise: a
// burst beyond the limit is refused as too many pending, and once the acks have come the
// client may fill the queue again.
TEST(PendingDeforms, DeformsBeyondTheUnacknowledgedLimitAreRefusedUntilAcksFreeTheirSlots) {
  const std::string dir = temp_data_dir("pending");
  ServerProcess server;
  // One tick a second keeps a burst in one queue; the rate limit stays out of the way.
  ASSERT_TRUE(server.start(dir, {"--max-pending-deforms", "3", "--tick-hz", "1", "--deforms-per-second",
                                 "1000", "--deform-burst", "1000"}))
      << server.log();
  client::TerrainClient c;
  ASSERT_TRUE(c.connect("127.0.0.1", server.port(), "eager").ok());
  EXPECT_EQ(c.welcome().limits.max_pending_deforms, 3u);
  StampRng rng(5);
  uint32_t next_seq = 1000;
  // All Deforms of a burst go in one write, so the server reads them before any tick runs.
  auto burst = [&](int n) {
    const std::vector<uint32_t> seqs = send_raw_deforms(c, rng, next_seq, n);
    EXPECT_TRUE(all_answered(c, seqs)) << server.log();
    int accepted = 0, too_many = 0;
    for (uint32_t s : seqs) {
      const auto a = c.ack(s);
      if (!a) continue;
      accepted += a->accepted ? 1 : 0;
      too_many += !a->accepted && a->code == wire::WireErrorCode::kTooManyPending ? 1 : 0;
    }
    return std::pair{accepted, too_many};
  };
  EXPECT_EQ(burst(5), (std::pair{3, 2})) << "three slots, five deforms";
  EXPECT_EQ(burst(3), (std::pair{3, 0})) << "the acks of the first burst freed every slot";
  EXPECT_TRUE(c.connection().open());
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

}  // namespace
}  // namespace loam::test
