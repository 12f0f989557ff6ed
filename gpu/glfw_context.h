// The client's windowed OpenGL 4.5 core context through GLFW (the server and the tests use
// the headless EglContext instead). Owns the window and, through a process-wide count, GLFW
// itself: glfwTerminate runs when the last window goes. GL entry points come from libepoxy,
// which resolves them for whichever context is current. GL debug output is installed in
// debug builds. Not thread-safe: GLFW wants the main thread.
#pragma once

#include <string>

#include "protocol/result.h"

struct GLFWwindow;

namespace loam::gpu {

struct WindowOptions {
  int width = 1280;
  int height = 720;
  std::string title = "Loam";
  bool vsync = true;
  bool visible = true;  // false: an offscreen window (tests under Xvfb)
};

class GlfwContext {
 public:
  // Errors: GLFW cannot initialise (no display), or no OpenGL 4.5 core context.
  static Result<GlfwContext> create(const WindowOptions& options = {});

  GlfwContext(GlfwContext&& other) noexcept;
  GlfwContext& operator=(GlfwContext&& other) noexcept;
  GlfwContext(const GlfwContext&) = delete;
  GlfwContext& operator=(const GlfwContext&) = delete;
  ~GlfwContext();

  GLFWwindow* window() const { return window_; }
  void make_current() const;
  void swap_buffers() const;
  bool should_close() const;
  static void poll_events();
  const std::string& renderer() const { return renderer_; }

 private:
  GlfwContext() = default;
  void release();
  GLFWwindow* window_ = nullptr;
  std::string renderer_;
};

}  // namespace loam::gpu
