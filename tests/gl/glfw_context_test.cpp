// The client's GLFW window context. Needs an X display: run under xvfb-run; skipped (also
// in CI, where the headless EGL tests are what must pass) when DISPLAY is unset.
#include <gtest/gtest.h>

#include <cstdlib>

#ifdef LOAM_HAVE_GLFW
#include <epoxy/gl.h>

#include "gpu/glfw_context.h"
#include "gpu/shader_library.h"

namespace loam::gpu {
namespace {

TEST(GlfwContext, HiddenWindowGivesCoreContextThatBuildsEmbeddedShaders) {
  if (std::getenv("DISPLAY") == nullptr) GTEST_SKIP() << "no DISPLAY (run under xvfb-run)";
  auto ctx = GlfwContext::create(
      {.width = 64, .height = 64, .title = "loam test", .vsync = false, .visible = false});
  ASSERT_TRUE(ctx.ok()) << ctx.error().describe();
  std::printf("GLFW window context: %s, %s\n", ctx->renderer().c_str(),
              reinterpret_cast<const char*>(glGetString(GL_VERSION)));
  GLint major = 0;
  glGetIntegerv(GL_MAJOR_VERSION, &major);
  EXPECT_GE(major, 4);
  {
    // Built and deleted while the window's context is current.
    const ShaderDefine defines[] = {{"SELFTEST_MULTIPLIER", "3"}};
    auto program = build_compute_program("selftest.comp.glsl", defines);
    EXPECT_TRUE(program.ok());
  }
  GlfwContext moved = std::move(*ctx);
  moved.swap_buffers();
  GlfwContext::poll_events();
  EXPECT_FALSE(moved.should_close());
}

}  // namespace
}  // namespace loam::gpu
#endif
