// Golden-image comparison shared by the GL tests: a rendered RGBA picture is compared with the
// committed PNG in tests/golden/images/ by OpenImageIO's idiff. The threshold: fail when more
// than 1% of pixels differ by more than 2/255, or any pixel by more than half the range. On
// failure the rendered image and an absolute difference image (x10) are left in golden-out/
// beside the test binary's working folder. LOAM_APPROVE_GOLDENS=<folder> writes the pictures
// there instead of comparing (scripts/approve-goldens.sh).
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "client/render/offscreen_target.h"
#include "gl_test_context.h"

namespace loam::render::test {

inline constexpr const char* kIdiffThresholds =
    "-fail 0.008 -failpercent 1 -warn 0.008 -warnpercent 1 -hardfail 0.5";

// Compares a picture with the golden `name`.png, or writes it to LOAM_APPROVE_GOLDENS.
inline void compare_with_golden(const std::string& name, int32_t width, int32_t height,
                                const std::vector<uint8_t>& rgba) {
  namespace fs = std::filesystem;
  const char* approve = std::getenv("LOAM_APPROVE_GOLDENS");
  const fs::path golden_dir = fs::path(LOAM_SOURCE_DIR) / "tests/golden/images";
  const fs::path out_dir = fs::absolute("golden-out");
  fs::create_directories(out_dir);
  const fs::path out = approve ? fs::path(approve) / (name + ".png") : out_dir / (name + ".png");
  ASSERT_TRUE(write_png(out.string(), width, height, rgba).ok());
  if (approve) {
    std::printf("approved %s\n", out.c_str());
    return;
  }
  const fs::path golden = golden_dir / (name + ".png"), diff = out_dir / (name + ".diff.png");
  ASSERT_TRUE(fs::exists(golden)) << golden << " is missing: run scripts/approve-goldens.sh";
  const std::string cmd = std::string("idiff -q ") + kIdiffThresholds + " -abs -scale 10 -od -o '" +
                          diff.string() + "' '" + golden.string() + "' '" + out.string() + "'";
  const int rc = std::system(cmd.c_str());
  EXPECT_EQ(rc, 0) << name << ": the render differs from its golden beyond the threshold ("
                   << kIdiffThresholds << "); rendered " << out << ", difference x10 in " << diff
                   << "; if the change is intended, run scripts/approve-goldens.sh";
}

}  // namespace loam::render::test

// Whether goldens can be checked here (idiff present) or are being approved; skips otherwise.
#define LOAM_REQUIRE_IDIFF()                                                                            \
  do {                                                                                                  \
    if (std::system("idiff --version > /dev/null 2>&1") != 0 && !std::getenv("LOAM_APPROVE_GOLDENS")) { \
      if (::loam::gpu::test::running_in_ci()) FAIL() << "idiff (openimageio-tools) is missing";         \
      GTEST_SKIP() << "idiff (openimageio-tools) is missing";                                           \
    }                                                                                                   \
  } while (0)
