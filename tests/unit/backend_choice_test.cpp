// The stamp backend choice (gpu/backend_choice.h), without a GL context.
#include "gpu/backend_choice.h"

#include <gtest/gtest.h>

namespace loam::gpu {
namespace {

TEST(BackendChoice, ParsesTheThreeNamesAndRejectsOthers) {
  EXPECT_EQ(parse_backend_kind("auto").value(), BackendKind::kAuto);
  EXPECT_EQ(parse_backend_kind("gpu").value(), BackendKind::kGpu);
  EXPECT_EQ(parse_backend_kind("cpu").value(), BackendKind::kCpu);
  auto bad = parse_backend_kind("GPU");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.error().field, "backend");
}

// llvmpipe is slower than the CPU reference, so auto must not pick it.
TEST(BackendChoice, AutoTakesOnlyHardwareGpus) {
  EXPECT_EQ(decide_backend(BackendKind::kAuto, {true, false}), BackendDecision::kGpu);
  EXPECT_EQ(decide_backend(BackendKind::kAuto, {true, true}), BackendDecision::kCpu);
  EXPECT_EQ(decide_backend(BackendKind::kAuto, {false, false}), BackendDecision::kCpu);
}

// Forcing gpu takes llvmpipe (the tests rely on it) and never falls back silently.
TEST(BackendChoice, ForcedGpuTakesSoftwareAndFailsWithoutEgl) {
  EXPECT_EQ(decide_backend(BackendKind::kGpu, {true, true}), BackendDecision::kGpu);
  EXPECT_EQ(decide_backend(BackendKind::kGpu, {false, false}), BackendDecision::kError);
  EXPECT_EQ(decide_backend(BackendKind::kCpu, {true, false}), BackendDecision::kCpu);
}

}  // namespace
}  // namespace loam::gpu
