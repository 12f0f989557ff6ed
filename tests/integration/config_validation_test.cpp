// Start-up checks of the real programs: every numeric option of loam-server, loam-client and
// loam-probe, given as a flag or as a --config key, is refused out of range or not finite with
// the option named; `render` refuses a camera that has no view; `tokens new FILE` writes a
// private file; serve warns about a tokens file others can read.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "integration_util.h"
#include "program_run.h"
#include "protocol/wire/access_token.h"
#include "server_process.h"

namespace loam::test {
namespace {

// `loam-server serve` with a throwaway data folder and an ephemeral port, plus `extra`; the
// checks refuse before anything is opened, so a refused run never listens.
Ran serve(const std::vector<std::string>& extra, const std::vector<std::string>& before_serve = {}) {
  std::vector<std::string> args = {LOAM_SERVER_BINARY};
  args.insert(args.end(), before_serve.begin(), before_serve.end());
  const std::vector<std::string> tail = {"serve", "--port", "0", "--data-dir", temp_data_dir("serve")};
  args.insert(args.end(), tail.begin(), tail.end());
  args.insert(args.end(), extra.begin(), extra.end());
  return run(args);
}

bool mentions(const Ran& r, const std::string& what) { return r.output.find(what) != std::string::npos; }

// The bug: `--max-radius nan` was taken, and NaN turned off every radius check, the 65536 hard
// cap included.
TEST(ConfigValidation, MaxRadiusNanIsRefusedNamingTheOption) {
  const Ran r = serve({"--max-radius", "nan"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_TRUE(mentions(r, "--max-radius: must be a finite number in (0, 65536], got nan")) << r.output;
  for (const char* bad : {"inf", "-1", "0", "65537", "1e400"}) {
    const Ran b = serve({"--max-radius", bad});
    EXPECT_NE(b.exit_code, 0) << bad;
    EXPECT_TRUE(mentions(b, "--max-radius: must be a finite number")) << bad << ": " << b.output;
  }
}

// Every numeric serve option, each with a value outside its range (or not a finite number).
TEST(ConfigValidation, EveryNumericServeOptionRefusesOutOfRangeValues) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--port", "70000"},
      {"--port", "-1"},
      {"--tick-hz", "0"},
      {"--tick-hz", "1001"},
      {"--max-clients", "0"},
      {"--max-frame-bytes", "10"},
      {"--max-subscriptions", "0"},
      {"--max-pending-deforms", "0"},
      {"--deforms-per-second", "nan"},
      {"--deforms-per-second", "0"},
      {"--deform-burst", "inf"},
      {"--deform-burst", "0.5"},
      {"--max-handshakes", "0"},
      {"--max-stamp-cost", "0"},
      {"--stamp-cost-per-second", "-3"},
      {"--tick-stamp-cost", "0"},
      {"--max-handshakes-per-address", "0"},
      {"--requests-per-second", "nan"},
      {"--requests-per-second", "0"},
      {"--request-burst", "0.5"},
      {"--best-after-uses", "-1"},
      {"--history-bytes", "-1"},
      {"--handshake-timeout", "nan"},
      {"--handshake-timeout", "0"},
      {"--idle-timeout", "-1"},
      {"--idle-timeout", "nan"},
      {"--max-queue-bytes", "100"},
      {"--snapshot-every", "-5"},
      {"--snapshot-interval", "nan"},
      {"--snapshot-dirty-mb", "-1"},
      {"--keep-snapshots", "0"},
      {"--log-retention-mb", "some"},
      {"--log-retention-mb", "nan"},
      {"--prefetch-tiles", "70000"},
      {"--hashes-every", "-1"},
      {"--stats-interval", "inf"},
      {"--max-radius", "-inf"},
  };
  for (const auto& [flag, value] : cases) {
    const Ran r = serve({flag, value});
    EXPECT_NE(r.exit_code, 0) << flag << " " << value;
    EXPECT_TRUE(mentions(r, flag + ": must be")) << flag << " " << value << ": " << r.output;
  }
}

// The --config file goes through the same checks as the flags (CLI11 validates its values).
TEST(ConfigValidation, IniKeyOutOfRangeIsRefused) {
  const std::string dir = temp_data_dir("ini");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"max-radius", "nan"}, {"tick-hz", "0"}, {"max-clients", "70000"}, {"deform-burst", "-3"}};
  for (const auto& [key, value] : cases) {
    const std::string ini = dir + "/" + key + ".ini";
    std::ofstream(ini) << "[serve]\n" << key << " = " << value << "\n";
    const Ran r = serve({}, {"--config", ini});
    EXPECT_NE(r.exit_code, 0) << key;
    EXPECT_TRUE(mentions(r, "--" + key + ": must be")) << key << ": " << r.output;
  }
}

TEST(ConfigValidation, TokensNewCountsAreRangeChecked) {
  const Ran r = run({LOAM_SERVER_BINARY, "tokens", "new", "--editors", "1001"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_TRUE(mentions(r, "--editors: must be an integer in 0..1000, got 1001")) << r.output;
}

// `loam-server tokens new FILE` was refused: the tokens could only go to stdout, and from
// there to a file the shell's umask left readable by everyone.
TEST(ConfigValidation, TokensNewWritesFileWithMode0600) {
  const std::string dir = temp_data_dir("tokensnew");
  const std::string file = dir + "/tokens";
  const mode_t old_mask = ::umask(022);  // the usual mask: a plain redirect would give 0644
  const Ran r = run({LOAM_SERVER_BINARY, "tokens", "new", file, "--editors", "2"});
  ::umask(old_mask);
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_EQ(r.output, "");  // nothing secret on the terminal
  struct stat st {};
  ASSERT_EQ(::stat(file.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0600u);
  std::ifstream in(file);
  std::stringstream text;
  text << in.rdbuf();
  wire::AccessTokenList tokens;
  ASSERT_TRUE(wire::parse_token_lines(text.str(), file, tokens).ok());
  EXPECT_EQ(tokens.editors.size(), 2u);
  EXPECT_EQ(tokens.viewers.size(), 1u);

  // An existing file is not overwritten without --force.
  const Ran again = run({LOAM_SERVER_BINARY, "tokens", "new", file});
  EXPECT_NE(again.exit_code, 0);
  EXPECT_TRUE(mentions(again, "already exists")) << again.output;
  std::ifstream still(file);
  std::stringstream unchanged;
  unchanged << still.rdbuf();
  EXPECT_EQ(unchanged.str(), text.str());

  // --force replaces it, and the new file is 0600 too (even over a file that was not).
  ASSERT_EQ(::chmod(file.c_str(), 0644), 0);
  const Ran forced = run({LOAM_SERVER_BINARY, "tokens", "new", file, "--force"});
  ASSERT_EQ(forced.exit_code, 0) << forced.output;
  ASSERT_EQ(::stat(file.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0600u);
  std::ifstream replaced(file);
  std::stringstream fresh;
  fresh << replaced.rdbuf();
  EXPECT_NE(fresh.str(), text.str());
  std::vector<std::string> left;
  for (const auto& e : std::filesystem::directory_iterator(dir)) left.push_back(e.path().filename().string());
  EXPECT_EQ(left, std::vector<std::string>{"tokens"});  // no temporary file left beside it
}

TEST(ConfigValidation, TokensNewWithoutFileStillPrintsToStdout) {
  const Ran r = run({LOAM_SERVER_BINARY, "tokens", "new", "--viewers", "0"});
  ASSERT_EQ(r.exit_code, 0) << r.output;
  wire::AccessTokenList tokens;
  ASSERT_TRUE(wire::parse_token_lines(r.output, "stdout", tokens).ok()) << r.output;
  EXPECT_EQ(tokens.editors.size(), 1u);
  EXPECT_EQ(tokens.viewers.size(), 0u);
}

// A tokens file its group or others can read is a leaked secret waiting to happen: serve
// says so in its log (and still starts: the operator may have reasons), a 0600 one is quiet.
TEST(ConfigValidation, GroupReadableTokensFileIsWarned) {
  const std::string dir = temp_data_dir("exposed");
  const std::string file = dir + "/tokens";
  std::ofstream(file) << "editor 00112233445566778899aabbccddeeff\n";
  ASSERT_EQ(::chmod(file.c_str(), 0640), 0);
  ServerProcess exposed;
  ASSERT_TRUE(exposed.start(dir + "/data", {"--tokens-file", file})) << exposed.log();
  EXPECT_EQ(exposed.terminate(), 0);
  const std::string log = exposed.log();
  EXPECT_NE(log.find("event=warning tokens_file=" + file + " mode=0640"), std::string::npos) << log;

  ASSERT_EQ(::chmod(file.c_str(), 0600), 0);
  ServerProcess private_file;
  ASSERT_TRUE(private_file.start(dir + "/data2", {"--tokens-file", file})) << private_file.log();
  EXPECT_EQ(private_file.terminate(), 0);
  EXPECT_EQ(private_file.log().find("tokens_file="), std::string::npos) << private_file.log();
}

#ifdef LOAM_PROBE_BINARY
TEST(ConfigValidation, ProbeRefusesNanTimeoutAndPortZero) {
  const Ran nan = run({LOAM_PROBE_BINARY, "--timeout", "nan"});
  EXPECT_NE(nan.exit_code, 0);
  EXPECT_TRUE(mentions(nan, "--timeout: must be a finite number in [0.1, 600], got nan")) << nan.output;
  const Ran port = run({LOAM_PROBE_BINARY, "--port", "0"});
  EXPECT_NE(port.exit_code, 0);
  EXPECT_TRUE(mentions(port, "--port: must be an integer in 1..65535, got 0")) << port.output;
}
#endif

#ifdef LOAM_CLIENT_BINARY
TEST(ConfigValidation, ClientBotAndProbeRefuseOutOfRangeNumbers) {
  const std::vector<std::vector<std::string>> cases = {
      {"bot", "--rate", "nan"},      {"bot", "--port", "70000"}, {"bot", "--stamps", "-1"},
      {"probe", "--timeout", "inf"}, {"probe", "--port", "0"},
  };
  for (const auto& c : cases) {
    std::vector<std::string> args = {LOAM_CLIENT_BINARY};
    args.insert(args.end(), c.begin(), c.end());
    const Ran r = run(args);
    EXPECT_NE(r.exit_code, 0) << c[0] << " " << c[1];
    EXPECT_TRUE(mentions(r, c[1] + ": must be")) << c[0] << " " << c[1] << ": " << r.output;
  }
}
#endif

#if defined(LOAM_CLIENT_BINARY) && defined(LOAM_CLIENT_HAS_RENDER)
Ran render(const std::vector<std::string>& extra) {
  std::vector<std::string> args = {LOAM_CLIENT_BINARY, "render", "--out", temp_data_dir("render") + "/r.png"};
  args.insert(args.end(), extra.begin(), extra.end());
  return run(args);
}

TEST(ConfigValidation, RenderRefusesCameraAtLookPoint) {
  const Ran r = render({"--camera", "1000,800,300", "--look", "1000,800,300"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_TRUE(mentions(r, "--camera/--look: the camera is at its look point")) << r.output;
}

TEST(ConfigValidation, RenderRefusesNonFiniteCameraAndLook) {
  const Ran cam = render({"--camera", "nan,800,300"});
  EXPECT_NE(cam.exit_code, 0);
  EXPECT_TRUE(mentions(cam, "--camera: must be a finite number, got nan")) << cam.output;
  const Ran look = render({"--look", "1000,inf,60"});
  EXPECT_NE(look.exit_code, 0);
  EXPECT_TRUE(mentions(look, "--look: must be a finite number, got inf")) << look.output;
}

TEST(ConfigValidation, RenderRefusesFovOf0And180) {
  for (const char* fov : {"0", "180", "nan", "-10"}) {
    const Ran r = render({"--fov", fov});
    EXPECT_NE(r.exit_code, 0) << fov;
    EXPECT_TRUE(mentions(r, std::string("--fov: must be a finite number in (0, 180), got ") + fov))
        << r.output;
  }
}

TEST(ConfigValidation, RenderRefusesNanViewDistance) {
  for (const char* d : {"nan", "0", "-5", "inf"}) {
    const Ran r = render({"--view-distance", d});
    EXPECT_NE(r.exit_code, 0) << d;
    EXPECT_TRUE(mentions(r, "--view-distance: must be a finite number in (0, 10000000]")) << r.output;
  }
}

// Straight down is parallel to the up vector: the look-at matrix has no sideways axis.
TEST(ConfigValidation, RenderRefusesAVerticalView) {
  const Ran r = render({"--camera", "1000,800,900", "--look", "1000,800,0"});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_TRUE(mentions(r, "straight up or down")) << r.output;
}

// Pictures are written as PNG: another name is refused before anything is drawn.
TEST(ConfigValidation, RenderAndViewRefuseAPictureNameThatIsNotPng) {
  const std::string jpg = temp_data_dir("render") + "/r.jpg";
  const Ran r = run({LOAM_CLIENT_BINARY, "render", "--out", jpg});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_TRUE(mentions(r, "--out: must name a .png file, got " + jpg)) << r.output;
#ifdef LOAM_CLIENT_HAS_VIEWER
  const Ran v = run({LOAM_CLIENT_BINARY, "view", "--headless", "--screenshot", "shot.tif"});
  EXPECT_NE(v.exit_code, 0);
  EXPECT_TRUE(mentions(v, "--screenshot: must name a .png file, got shot.tif")) << v.output;
#endif
}

// A camera path file is held to the same rules, naming its line.
TEST(ConfigValidation, RenderRefusesACameraPathLineAtItsLookPoint) {
  const std::string path = temp_data_dir("path") + "/cameras.txt";
  std::ofstream(path) << "1000 1700 300 1000 800 60\n5 5 5 5 5 5\n";
  const Ran r = render({"--path", path});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_TRUE(mentions(r, path + ":2")) << r.output;
}
#endif

#if defined(LOAM_CLIENT_BINARY) && defined(LOAM_CLIENT_HAS_VIEWER)
TEST(ConfigValidation, ViewRefusesNanViewDistanceAndPortZero) {
  const Ran d = run({LOAM_CLIENT_BINARY, "view", "--headless", "--view-distance", "nan"});
  EXPECT_NE(d.exit_code, 0);
  // 0 is the world's own view distance (render/start_view.h); NaN and negatives are refused.
  EXPECT_TRUE(mentions(d, "--view-distance: must be a finite number in [0, 10000000], got nan")) << d.output;
  const Ran n = run({LOAM_CLIENT_BINARY, "view", "--headless", "--view-distance", "-1"});
  EXPECT_NE(n.exit_code, 0);
  EXPECT_TRUE(mentions(n, "--view-distance: must be a finite number in [0, 10000000], got -1")) << n.output;
  const Ran p = run({LOAM_CLIENT_BINARY, "view", "--headless", "--port", "0"});
  EXPECT_NE(p.exit_code, 0);
  EXPECT_TRUE(mentions(p, "--port: must be an integer in 1..65535, got 0")) << p.output;
}
#endif

}  // namespace
}  // namespace loam::test
