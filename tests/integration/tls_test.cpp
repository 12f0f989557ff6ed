// TLS on the client connection: certificates made at test time (test_ca.h), a real server
// process with --tls-cert/--tls-key, clients verifying it by CA (with the host name) or by a
// pinned fingerprint, what crosses the wire, and the clear errors of every mismatch.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include "client/bot.h"
#include "client/net/terrain_client.h"
#include "fault_proxy.h"
#include "integration_util.h"
#include "metrics_scrape.h"
#include "program_run.h"
#include "protocol/wire/access_token.h"
#include "server_process.h"
#include "test_ca.h"
#include "transport/tls_context.h"

namespace loam::test {
namespace {

using namespace std::chrono_literals;

constexpr const char* kEditor = "00112233445566778899aabbccddeeff";

transport::TlsClientOptions by_ca(const std::string& ca, const std::string& name = "") {
  transport::TlsClientOptions o;
  o.enabled = true;
  o.ca_file = ca;
  o.server_name = name;
  return o;
}

transport::TlsClientOptions by_pin(const std::string& fingerprint) {
  transport::TlsClientOptions o;
  o.enabled = true;
  o.fingerprint = fingerprint;
  return o;
}

bool contains(const std::vector<uint8_t>& haystack, const std::array<uint8_t, 16>& needle) {
  return std::search(haystack.begin(), haystack.end(), needle.begin(), needle.end()) != haystack.end();
}

// Joins as a spectator over TLS with `tls`; the handshake's outcome.
Status spectate(const transport::TlsClientOptions& tls, const std::string& host, uint16_t port) {
  client::TerrainClient c;
  c.set_tls(tls);
  return c.connect(host, port, "spectator", wire::Role::kSpectator);
}

class Tls : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = temp_data_dir("tls");
    certs_ = make_test_certificates(dir_ + "/certs");
  }
  std::vector<std::string> tls_flags() const {
    return {"--tls-cert", certs_.server_cert, "--tls-key", certs_.server_key};
  }
  std::string fingerprint() const {
    auto f = transport::certificate_fingerprint(certs_.server_cert);
    EXPECT_TRUE(f.ok());
    return f.ok() ? transport::fingerprint_text(*f) : "";
  }
  std::string dir_;
  TestCertificates certs_;
};

TEST_F(Tls, AClientVerifyingTheCaDeformsConvergesAndItsTokenNeverCrossesInClear) {
  auto flags = tls_flags();
  flags.insert(flags.end(), {"--editor-token", kEditor});
  ServerProcess server;
  ASSERT_TRUE(server.start(dir_ + "/data", flags)) << server.log();
  EXPECT_NE(server.log().find("tls=on"), std::string::npos) << server.log();
  FaultProxy wire_tap(server.port(), {});
  const auto token = *wire::parse_access_token(kEditor);

  client::TerrainClient c;
  c.set_tls(by_ca(certs_.ca_cert));
  const Status joined = c.connect("127.0.0.1", wire_tap.port(), "tls-editor", wire::Role::kPlayer, token);
  ASSERT_TRUE(joined.ok()) << joined.error().describe() << "\n" << server.log();
  StampRng rng(11);
  std::vector<uint32_t> sent;
  for (int i = 0; i < 20; ++i) {
    auto s = c.deform(random_stamp(rng, c.welcome().world));
    ASSERT_TRUE(s.ok());
    sent.push_back(*s);
  }
  ASSERT_TRUE(c.wait_until([&] { return c.ack(sent.back()).has_value(); }, 30s));
  for (const uint32_t s : sent) EXPECT_TRUE(c.ack(s)->accepted);
  const uint64_t last = c.ack(sent.back())->global_seq;
  const World expected = replayed_world(dir_ + "/data", last);
  ASSERT_TRUE(c.subscribe(c.all_coarse_tiles()).ok());
  EXPECT_TRUE(c.wait_until([&] { return bool(store_matches(c, expected)); }, 60s))
      << store_matches(c, expected);

  const std::vector<uint8_t> bytes = wire_tap.client_bytes();
  ASSERT_GT(bytes.size(), 1000u);
  EXPECT_FALSE(contains(bytes, token)) << "the token crossed the wire in clear";
  // The check can fail: without TLS the same Hello carries it as it is.
  ServerProcess plain;
  ASSERT_TRUE(plain.start(dir_ + "/plain", {"--editor-token", kEditor})) << plain.log();
  FaultProxy plain_tap(plain.port(), {});
  client::TerrainClient p;
  ASSERT_TRUE(p.connect("127.0.0.1", plain_tap.port(), "plain-editor", wire::Role::kPlayer, token).ok());
  EXPECT_TRUE(contains(plain_tap.client_bytes(), token));
}

TEST_F(Tls, APinnedFingerprintJoinsWithoutACaAndAnyOtherIsRefused) {
  ServerProcess server;
  ASSERT_TRUE(server.start(dir_ + "/data", tls_flags())) << server.log();
  const std::string pin = fingerprint();
  // The server says what to pin.
  EXPECT_NE(server.log().find("event=tls certificate=" + certs_.server_cert + " sha256=" + pin),
            std::string::npos)
      << server.log();
  const Status ok = spectate(by_pin(pin), "127.0.0.1", server.port());
  EXPECT_TRUE(ok.ok()) << ok.error().describe();
  // Lower case without colons is the same pin.
  std::string bare;
  for (const char ch : pin)
    if (ch != ':') bare.push_back(char(std::tolower(static_cast<unsigned char>(ch))));
  EXPECT_TRUE(spectate(by_pin(bare), "127.0.0.1", server.port()).ok());

  std::string wrong = pin;
  wrong[0] = wrong[0] == 'A' ? 'B' : 'A';
  const Status refused = spectate(by_pin(wrong), "127.0.0.1", server.port());
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kUnauthorized) << refused.error().describe();
  EXPECT_NE(refused.error().describe().find("TLS handshake"), std::string::npos)
      << refused.error().describe();

  const Status bad = spectate(by_pin("12:34"), "127.0.0.1", server.port());
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().code, ErrorCode::kInvalidArgument) << bad.error().describe();
}

TEST_F(Tls, AServerOutsideTheCaOrUnderAnotherNameIsRefused) {
  ServerProcess server;
  ASSERT_TRUE(server.start(dir_ + "/data", tls_flags())) << server.log();
  const Status untrusted = spectate(by_ca(certs_.other_ca_cert), "127.0.0.1", server.port());
  ASSERT_FALSE(untrusted.ok());
  EXPECT_NE(untrusted.error().describe().find("TLS handshake"), std::string::npos)
      << untrusted.error().describe();

  EXPECT_FALSE(spectate(by_ca(certs_.ca_cert, "elsewhere.example"), "127.0.0.1", server.port()).ok());
  // The certificate's DNS name passes as well as its address.
  const Status named = spectate(by_ca(certs_.ca_cert), "localhost", server.port());
  EXPECT_TRUE(named.ok()) << named.error().describe();

  const Status no_file = spectate(by_ca(dir_ + "/no-such-ca.pem"), "127.0.0.1", server.port());
  ASSERT_FALSE(no_file.ok());
  EXPECT_EQ(no_file.error().code, ErrorCode::kIo) << no_file.error().describe();
}

TEST_F(Tls, APlainClientIsRefusedAndTlsClientsAreServedAfterIt) {
  ServerProcess server;
  ASSERT_TRUE(server.start(dir_ + "/data", tls_flags())) << server.log();
  client::TerrainClient plain;
  const Status refused = plain.connect("127.0.0.1", server.port(), "plain", wire::Role::kSpectator);
  EXPECT_FALSE(refused.ok());
  client::Connection raw;
  wire::Hello hello;
  hello.client_name = "raw";
  EXPECT_FALSE(raw.connect("127.0.0.1", server.port(), hello, 5s).ok());
  client::TerrainClient good;
  good.set_tls(by_ca(certs_.ca_cert));
  const Status ok = good.connect("127.0.0.1", server.port(), "good", wire::Role::kPlayer);
  ASSERT_TRUE(ok.ok()) << ok.error().describe();
  StampRng rng(5);
  auto s = good.deform(random_stamp(rng, good.welcome().world));
  ASSERT_TRUE(s.ok());
  ASSERT_TRUE(good.wait_until([&] { return good.ack(*s).has_value(); }, 30s));
  EXPECT_TRUE(good.ack(*s)->accepted);
  EXPECT_NE(server.log().find("event=tls_handshake_failed"), std::string::npos) << server.log();
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

TEST_F(Tls, MetricsCountFailedTlsHandshakes) {
  auto flags = tls_flags();
  flags.insert(flags.end(), {"--metrics-bind", "127.0.0.1:0"});
  ServerProcess server;
  ASSERT_TRUE(server.start(dir_ + "/data", flags)) << server.log();
  client::TerrainClient plain;
  EXPECT_FALSE(plain.connect("127.0.0.1", server.port(), "plain", wire::Role::kSpectator).ok());
  const std::string want = "loam_tls_handshake_failures_total 1";
  std::string text;
  for (int i = 0; i < 100 && text.find(want) == std::string::npos; ++i) {
    text = http_get_metrics(server);
    if (text.find(want) == std::string::npos) std::this_thread::sleep_for(50ms);
  }
  EXPECT_NE(text.find(want), std::string::npos) << text;
}

TEST_F(Tls, ATlsClientOfAPlainServerGetsAClearError) {
  ServerProcess server;
  ASSERT_TRUE(server.start(dir_ + "/data")) << server.log();
  const Status st = spectate(by_ca(certs_.ca_cert), "127.0.0.1", server.port());
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().describe().find("TLS handshake"), std::string::npos) << st.error().describe();
}

TEST_F(Tls, TheServerRefusesToStartOnAKeyThatIsNotTheCertificatesOrACertificateAlone) {
  ServerProcess mismatched;
  EXPECT_FALSE(
      mismatched.start(dir_ + "/a", {"--tls-cert", certs_.server_cert, "--tls-key", certs_.other_key}, 20s));
  EXPECT_NE(mismatched.log().find("does not match"), std::string::npos) << mismatched.log();
  ServerProcess alone;
  EXPECT_FALSE(alone.start(dir_ + "/b", {"--tls-cert", certs_.server_cert}, 20s));
  EXPECT_NE(alone.log().find("--tls-key"), std::string::npos) << alone.log();
  ServerProcess missing;
  EXPECT_FALSE(
      missing.start(dir_ + "/c", {"--tls-cert", dir_ + "/nope.pem", "--tls-key", certs_.server_key}, 20s));
  EXPECT_NE(missing.log().find("nope.pem"), std::string::npos) << missing.log();
}

TEST_F(Tls, TokensWithoutTlsOffLoopbackAreWarnedAbout) {
  ServerProcess clear;
  ASSERT_TRUE(clear.start(dir_ + "/clear", {"--bind", "0.0.0.0", "--editor-token", kEditor})) << clear.log();
  EXPECT_NE(clear.log().find("tokens configured without TLS"), std::string::npos) << clear.log();
  auto flags = tls_flags();
  flags.insert(flags.end(), {"--bind", "0.0.0.0", "--editor-token", kEditor});
  ServerProcess secured;
  ASSERT_TRUE(secured.start(dir_ + "/secured", flags)) << secured.log();
  EXPECT_EQ(secured.log().find("tokens configured without TLS"), std::string::npos) << secured.log();
  ServerProcess loopback;
  ASSERT_TRUE(loopback.start(dir_ + "/loopback", {"--editor-token", kEditor})) << loopback.log();
  EXPECT_EQ(loopback.log().find("tokens configured without TLS"), std::string::npos) << loopback.log();
}

#ifdef LOAM_CLIENT_BINARY
TEST_F(Tls, TheBotAndTheProbeConnectOverTls) {
  ServerProcess server;
  ASSERT_TRUE(server.start(dir_ + "/data", tls_flags())) << server.log();
  const Ran bot = run({LOAM_CLIENT_BINARY, "bot", "--port", std::to_string(server.port()), "--stamps", "5",
                       "--rate", "50", "--tls-ca", certs_.ca_cert});
  EXPECT_EQ(bot.exit_code, client::kBotOk) << bot.output;
  EXPECT_NE(bot.output.find("5/5 stamps accepted"), std::string::npos) << bot.output;
  const Ran probe = run({LOAM_CLIENT_BINARY, "probe", "--port", std::to_string(server.port()),
                         "--tls-fingerprint", fingerprint()});
  EXPECT_EQ(probe.exit_code, 0) << probe.output;
  const Ran plain_probe = run({LOAM_CLIENT_BINARY, "probe", "--port", std::to_string(server.port())});
  EXPECT_NE(plain_probe.exit_code, 0) << plain_probe.output;
}
#endif

}  // namespace
}  // namespace loam::test
