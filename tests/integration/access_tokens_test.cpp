// The server's access tokens: the access each token grants, loading them, and a
// server that refuses to start on a token it cannot read instead of running a session
// nobody can join.
#include "server/access_tokens.h"

#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "client/net/terrain_client.h"
#include "integration_util.h"
#include "protocol/wire/access_token.h"
#include "server/server_config.h"
#include "server_process.h"

namespace loam::server {
namespace {

constexpr const char* kEditor = "00112233445566778899aabbccddeeff";
constexpr const char* kViewer = "ffeeddccbbaa99887766554433221100";

wire::AccessToken tok(const char* hex) { return *wire::parse_access_token(hex); }

TEST(AccessTokens, EditorAsRequestedViewerAsSpectatorOthersDenied) {
  AccessTokens open;
  EXPECT_EQ(check_access(open, std::nullopt), Access::kAsRequested);
  AccessTokens t;
  t.editors.push_back(tok(kEditor));
  t.viewers.push_back(tok(kViewer));
  EXPECT_EQ(check_access(t, tok(kEditor)), Access::kAsRequested);
  EXPECT_EQ(check_access(t, tok(kViewer)), Access::kSpectator);
  EXPECT_EQ(check_access(t, std::nullopt), Access::kDenied);
  EXPECT_EQ(check_access(t, tok("0123456789abcdef0123456789abcdef")), Access::kDenied);
  AccessTokens broken;
  broken.deny_all = true;  // tokens were configured but could not be read: fail closed
  EXPECT_EQ(check_access(broken, std::nullopt), Access::kDenied);
}

TEST(AccessTokens, LoadValidatesFlagsAndFile) {
  ServerConfig c;
  c.editor_tokens = {"00112233445566778899aabbccddeefg"};
  auto bad_flag = load_access_tokens(c);
  ASSERT_FALSE(bad_flag.ok());
  EXPECT_EQ(bad_flag.error().field, "--editor-token");

  const std::string dir = test::temp_data_dir("tokens");
  std::filesystem::create_directories(dir);
  c.editor_tokens.clear();
  c.tokens_file = dir + "/missing";
  EXPECT_EQ(load_access_tokens(c).error().code, ErrorCode::kIo);
  c.tokens_file = dir + "/empty";
  std::ofstream(c.tokens_file) << "# nothing yet\n";
  auto empty = load_access_tokens(c);
  ASSERT_FALSE(empty.ok());  // an empty secret must not open the session to everyone
  EXPECT_NE(empty.error().message.find("no token"), std::string::npos);
  c.tokens_file = dir + "/good";
  std::ofstream(c.tokens_file) << "viewer " << kViewer << "\n";
  c.editor_tokens = {kEditor};
  auto good = load_access_tokens(c);
  ASSERT_TRUE(good.ok()) << good.error().describe();
  EXPECT_EQ(good->editors.size(), 1u);
  EXPECT_EQ(good->viewers.size(), 1u);
}

TEST(AccessTokens, ServerRefusesToStartOnAMalformedToken) {
  const std::string dir = test::temp_data_dir("badtoken");
  test::ServerProcess server;
  EXPECT_FALSE(server.start(dir, {"--viewer-token", "not-a-token"}));
  EXPECT_NE(server.log().find("--viewer-token"), std::string::npos) << server.log();
}

TEST(AccessTokens, TokensFileGrantsRolesToRealClients) {
  const std::string dir = test::temp_data_dir("tokensfile");
  std::filesystem::create_directories(dir);
  const std::string file = dir + "/tokens";
  std::ofstream(file) << "editor " << kEditor << "\nviewer " << kViewer << "\n";
  test::ServerProcess server;
  ASSERT_TRUE(server.start(dir + "/data", {"--tokens-file", file})) << server.log();
  client::TerrainClient editor, viewer, none;
  ASSERT_TRUE(editor.connect("127.0.0.1", server.port(), "e", wire::Role::kPlayer, tok(kEditor)).ok());
  EXPECT_EQ(editor.welcome().granted_role, wire::Role::kPlayer);
  ASSERT_TRUE(viewer.connect("127.0.0.1", server.port(), "v", wire::Role::kPlayer, tok(kViewer)).ok());
  EXPECT_EQ(viewer.welcome().granted_role, wire::Role::kSpectator);
  const Status refused = none.connect("127.0.0.1", server.port(), "n", wire::Role::kPlayer);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kUnauthorized) << refused.error().describe();
  EXPECT_NE(server.log().find("access=tokens editor_tokens=1 viewer_tokens=1"), std::string::npos);
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

// Waits (polling the server's log file, with a deadline) for a line holding `what`.
bool log_shows(const test::ServerProcess& server, const std::string& what) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < deadline) {
    if (server.log().find(what) != std::string::npos) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return false;
}

TEST(AccessTokens, SighupReadsARotatedTokensFileAndKeepsTheOldOnesWhenTheNewFileIsBad) {
  constexpr const char* kRotated = "0123456789abcdef0123456789abcdef";
  const std::string dir = test::temp_data_dir("rotate");
  const std::string file = dir + "/tokens";
  auto write_tokens = [&](const std::string& text) {  // as a mounted secret changes: a rename
    std::ofstream(file + ".new") << text;
    std::filesystem::rename(file + ".new", file);
  };
  write_tokens(std::string("editor ") + kEditor + "\n");
  test::ServerProcess server;
  ASSERT_TRUE(server.start(dir + "/data", {"--tokens-file", file})) << server.log();
  client::TerrainClient before;
  ASSERT_TRUE(before.connect("127.0.0.1", server.port(), "before", wire::Role::kPlayer, tok(kEditor)).ok());

  write_tokens(std::string("editor ") + kRotated + "\n");
  ::kill(server.pid(), SIGHUP);
  ASSERT_TRUE(log_shows(server, "event=tokens_reloaded access=tokens editor_tokens=1")) << server.log();
  client::TerrainClient rotated, stale;
  EXPECT_TRUE(
      rotated.connect("127.0.0.1", server.port(), "rotated", wire::Role::kPlayer, tok(kRotated)).ok());
  const Status refused =
      stale.connect("127.0.0.1", server.port(), "stale", wire::Role::kPlayer, tok(kEditor));
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kUnauthorized);
  // A client that joined before keeps its role: its stamp is accepted.
  StampRng rng(3);
  const auto sent = before.deform(test::random_stamp(rng, before.welcome().world));
  ASSERT_TRUE(sent.ok());
  ASSERT_TRUE(before.wait_until([&] { return before.ack(*sent).has_value(); }, std::chrono::seconds(30)));
  EXPECT_TRUE(before.ack(*sent)->accepted);

  write_tokens("editor not-hex\n");
  ::kill(server.pid(), SIGHUP);
  ASSERT_TRUE(log_shows(server, "event=tokens_reload_failed")) << server.log();
  client::TerrainClient still;
  EXPECT_TRUE(still.connect("127.0.0.1", server.port(), "still", wire::Role::kPlayer, tok(kRotated)).ok());
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

}  // namespace
}  // namespace loam::server
