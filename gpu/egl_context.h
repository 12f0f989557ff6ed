// A headless OpenGL 4.5 core context through EGL, with no window and no config
// (EGL_KHR_no_config_context), for the server's GPU stamp backend, headless renders and GL
// tests. Tries the EGL device platform (real GPUs: every device EGL enumerates) and Mesa's
// surfaceless platform (llvmpipe, or a GPU through Mesa). Owns the display and context; the
// destructor releases them. Not thread-safe: make it current on the thread that uses it, and
// release it there before another thread makes it current.
#pragma once

#include <epoxy/egl.h>

#include <string>

#include "protocol/result.h"

namespace loam::gpu {

// llvmpipe, softpipe, swrast, SwiftShader: a GL_RENDERER string of a CPU rasterizer.
bool is_software_renderer(const std::string& renderer);

enum class EglPreference {
  kAny,       // first device that gives a 4.5 core context (hardware first, then software)
  kHardware,  // only a hardware renderer; an error if there is none
};

class EglContext {
 public:
  static Result<EglContext> create(EglPreference preference = EglPreference::kAny);

  EglContext(EglContext&& other) noexcept;
  EglContext& operator=(EglContext&& other) noexcept;
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;
  ~EglContext();

  Status make_current() const;
  // Leaves the calling thread with no current context if this one is current there, so
  // another thread may make it current next (a context is current on one thread at a time).
  void release_current() const;
  const std::string& renderer() const { return renderer_; }  // GL_RENDERER
  const std::string& version() const { return version_; }    // GL_VERSION
  const std::string& platform() const { return platform_; }  // "device" or "surfaceless"
  // llvmpipe, softpipe, swrast: a CPU rasterizer, slower than the CPU reference here.
  bool is_software() const;

 private:
  EglContext() = default;
  void release();

  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext context_ = EGL_NO_CONTEXT;
  std::string renderer_, version_, platform_;
};

}  // namespace loam::gpu
