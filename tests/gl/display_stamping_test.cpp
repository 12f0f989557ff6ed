// `loam-client view --stamping auto` (client/render/display_stamping.h): the display stamps on
// the CPU only where that is measured faster (a software rasterizer), on the GPU elsewhere; an
// explicit choice is kept whatever the renderer.
#include "client/render/display_stamping.h"

#include <gtest/gtest.h>

namespace loam::render {
namespace {

TEST(DisplayStamping, AutoTakesTheCpuOnASoftwareRasterizerAndTheGpuElsewhere) {
  const char* llvmpipe = "llvmpipe (LLVM 15.0.6, 256 bits)";
  const char* gpu = "NVIDIA H100 80GB HBM3/PCIe/SSE2";
  EXPECT_EQ(resolve_stamping(DisplayStamping::kAuto, llvmpipe), DisplayStamping::kCpu);
  EXPECT_EQ(resolve_stamping(DisplayStamping::kAuto, "softpipe"), DisplayStamping::kCpu);
  EXPECT_EQ(resolve_stamping(DisplayStamping::kAuto, gpu), DisplayStamping::kGpu);
  EXPECT_EQ(resolve_stamping(DisplayStamping::kAuto, nullptr), DisplayStamping::kGpu);
  EXPECT_EQ(resolve_stamping(DisplayStamping::kGpu, llvmpipe), DisplayStamping::kGpu);
  EXPECT_EQ(resolve_stamping(DisplayStamping::kCpu, gpu), DisplayStamping::kCpu);
  EXPECT_STREQ(to_string(DisplayStamping::kAuto), "auto");
}

}  // namespace
}  // namespace loam::render
