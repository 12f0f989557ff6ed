// Replay determinism on the GPU: the committed logs under tests/golden/replay/ replay to the
// same committed world hashes with the GPU stamp backend (llvmpipe here) as with the CPU.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include "gl_test_context.h"
#include "server/replay.h"

namespace loam {
namespace {

TEST(ReplayGpu, CommittedLogsReplayToCommittedWorldHashesWithTheGpuBackend) {
  LOAM_REQUIRE_GL();
  const std::string dir = std::string(LOAM_SOURCE_DIR) + "/tests/golden/replay";
  std::ifstream expected(dir + "/expected.txt");
  ASSERT_TRUE(expected) << "missing " << dir << "/expected.txt";
  // Per line: log, legacy content and world hashes, current content and world hashes.
  std::string name, legacy_content, legacy_hash, content, hash;
  int checked = 0;
  while (expected >> name >> legacy_content >> legacy_hash >> content >> hash) {
    auto r = server::replay_log({dir + "/" + name}, dir, std::numeric_limits<uint64_t>::max(),
                                gpu::BackendKind::kGpu);
    ASSERT_TRUE(r.ok()) << name << ": " << r.error().describe();
    char got[20];
    std::snprintf(got, sizeof got, "%016llx", (unsigned long long)r->world.world_hash());
    EXPECT_EQ(got, hash) << name;
    ++checked;
  }
  EXPECT_EQ(checked, 3);
}

}  // namespace
}  // namespace loam
