// Replay determinism: the committed logs under tests/golden/replay/ (log format 1, made by
// regenerate.sh before format 2; they also pin that old logs still replay) replay to the
// committed content hashes and world hashes (which cover the world's parameters too), in the
// legacy definition they were first pinned with and the current one, through the library and
// through the `loam-server replay` command a user runs.
#include "server/replay.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <sstream>

namespace loam::test {
namespace {

TEST(Replay, CommittedLogsReplayToCommittedWorldHashesWithTheCpuBackend) {
  const std::string dir = std::string(LOAM_SOURCE_DIR) + "/tests/golden/replay";
  std::ifstream expected(dir + "/expected.txt");
  ASSERT_TRUE(expected) << "missing " << dir << "/expected.txt";
  std::string name, legacy_content, legacy_hash, content, hash;
  int checked = 0;
  while (expected >> name >> legacy_content >> legacy_hash >> content >> hash) {
    auto r = server::replay_log({dir + "/" + name}, dir);
    ASSERT_TRUE(r.ok()) << name << ": " << r.error().describe();
    const auto hex = [](uint64_t v) {
      char got[20];
      std::snprintf(got, sizeof got, "%016llx", (unsigned long long)v);
      return std::string(got);
    };
    // The hashes every tile gives (as first pinned: the stamps replay to the same samples),
    // and the current definition (base identity plus edited tiles).
    EXPECT_EQ(hex(r->world.legacy_content_hash()), legacy_content) << name;
    EXPECT_EQ(hex(r->world.legacy_world_hash()), legacy_hash) << name;
    EXPECT_EQ(hex(r->world.content_hash()), content) << name;
    EXPECT_EQ(hex(r->world.world_hash()), hash) << name;
    // The same through the command line.
    const std::string cmd =
        std::string(LOAM_SERVER_BINARY) + " replay " + dir + "/" + name + " --data-dir " + dir;
    FILE* p = popen(cmd.c_str(), "r");
    ASSERT_NE(p, nullptr);
    std::stringstream out;
    char buf[256];
    while (fgets(buf, sizeof buf, p)) out << buf;
    EXPECT_EQ(pclose(p), 0) << out.str();
    EXPECT_NE(out.str().find("world hash " + hash), std::string::npos) << out.str();
    ++checked;
  }
  EXPECT_EQ(checked, 3);
}

}  // namespace
}  // namespace loam::test
