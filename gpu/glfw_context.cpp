#include "gpu/glfw_context.h"

#include <epoxy/gl.h>
// After epoxy: GLFW must not pull in a second set of GL declarations.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <utility>

#include "gpu/gl_debug.h"

namespace loam::gpu {

namespace {
int g_windows = 0;  // live windows: GLFW stays initialised while this is non-zero
std::string g_last_error;

void on_glfw_error(int code, const char* description) {
  g_last_error = std::to_string(code) + ": " + (description ? description : "");
}
}  // namespace

Result<GlfwContext> GlfwContext::create(const WindowOptions& options) {
  glfwSetErrorCallback(on_glfw_error);
  if (g_windows == 0 && !glfwInit()) {
    return make_error(ErrorCode::kUnsupported, "glfw", "glfwInit failed (no display?): " + g_last_error);
  }
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_VISIBLE, options.visible ? GLFW_TRUE : GLFW_FALSE);
#ifndef NDEBUG
  glfwWindowHint(GLFW_OPENGL_DEBUG_CONTEXT, GLFW_TRUE);
#endif
  GLFWwindow* window =
      glfwCreateWindow(options.width, options.height, options.title.c_str(), nullptr, nullptr);
  if (!window) {
    if (g_windows == 0) glfwTerminate();
    return make_error(ErrorCode::kUnsupported, "glfw", "no OpenGL 4.5 core window: " + g_last_error);
  }
  ++g_windows;
  GlfwContext out;
  out.window_ = window;
  out.make_current();
  glfwSwapInterval(options.vsync ? 1 : 0);
  install_gl_debug_output();
  const auto* r = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  out.renderer_ = r ? r : "unknown";
  return out;
}

GlfwContext::GlfwContext(GlfwContext&& other) noexcept
    : window_(std::exchange(other.window_, nullptr)), renderer_(std::move(other.renderer_)) {}

GlfwContext& GlfwContext::operator=(GlfwContext&& other) noexcept {
  if (this != &other) {
    release();
    window_ = std::exchange(other.window_, nullptr);
    renderer_ = std::move(other.renderer_);
  }
  return *this;
}

GlfwContext::~GlfwContext() { release(); }

void GlfwContext::release() {
  if (!window_) return;
  glfwDestroyWindow(window_);
  window_ = nullptr;
  if (--g_windows == 0) glfwTerminate();
}

void GlfwContext::make_current() const { glfwMakeContextCurrent(window_); }
void GlfwContext::swap_buffers() const { glfwSwapBuffers(window_); }
bool GlfwContext::should_close() const { return glfwWindowShouldClose(window_) != 0; }
void GlfwContext::poll_events() { glfwPollEvents(); }

}  // namespace loam::gpu
