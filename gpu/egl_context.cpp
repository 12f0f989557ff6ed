#include "gpu/egl_context.h"

#include <epoxy/gl.h>

#include <utility>
#include <vector>

namespace loam::gpu {
namespace {

Error egl_error(const std::string& what) {
  char code[16];
  std::snprintf(code, sizeof code, "0x%04x", unsigned(eglGetError()));
  return make_error(ErrorCode::kUnsupported, "egl", what + " (EGL error " + code + ")");
}

struct Candidate {
  EGLDisplay display;
  const char* platform;
};

// Every display EGL can open without a window system: each enumerated device, then Mesa's
// surfaceless platform.
std::vector<Candidate> candidate_displays() {
  std::vector<Candidate> out;
  if (epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_EXT_device_enumeration") &&
      epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_EXT_platform_device")) {
    EGLDeviceEXT devices[16];
    EGLint count = 0;
    if (eglQueryDevicesEXT(16, devices, &count)) {
      for (EGLint i = 0; i < count; ++i) {
        const EGLDisplay d = eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
        if (d != EGL_NO_DISPLAY) out.push_back({d, "device"});
      }
    }
  }
  if (epoxy_has_egl_extension(EGL_NO_DISPLAY, "EGL_MESA_platform_surfaceless")) {
    const EGLDisplay d =
        eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (d != EGL_NO_DISPLAY) out.push_back({d, "surfaceless"});
  }
  return out;
}

}  // namespace

Result<EglContext> EglContext::create(EglPreference preference) {
  const std::vector<Candidate> displays = candidate_displays();
  if (displays.empty())
    return egl_error("no EGL display: neither the device nor the surfaceless platform is available");
  std::string tried;
  // Two passes: hardware renderers first, then (for kAny) software ones.
  for (int pass = 0; pass < 2; ++pass) {
    for (const Candidate& c : displays) {
      EGLint major = 0, minor = 0;
      if (!eglInitialize(c.display, &major, &minor)) continue;
      if (!epoxy_has_egl_extension(c.display, "EGL_KHR_no_config_context") &&
          !epoxy_has_egl_extension(c.display, "EGL_MESA_configless_context")) {
        continue;
      }
      if (!eglBindAPI(EGL_OPENGL_API)) continue;
      // Attribute, value pairs.
      // clang-format off
      const EGLint attribs[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5,
                                EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
#ifndef NDEBUG
                                EGL_CONTEXT_OPENGL_DEBUG, EGL_TRUE,
#endif
                                EGL_NONE};
      // clang-format on
      const EGLContext ctx = eglCreateContext(c.display, EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, attribs);
      if (ctx == EGL_NO_CONTEXT) continue;
      if (!eglMakeCurrent(c.display, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx)) {
        eglDestroyContext(c.display, ctx);
        continue;
      }
      const auto* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
      const auto* version = reinterpret_cast<const char*>(glGetString(GL_VERSION));
      const std::string r = renderer ? renderer : "unknown";
      const bool software = is_software_renderer(r);
      if ((pass == 0 && software) || (pass == 1 && !software)) {
        eglMakeCurrent(c.display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        eglDestroyContext(c.display, ctx);
        if (pass == 0) tried += (tried.empty() ? "" : ", ") + r;
        continue;
      }
      EglContext out;
      out.display_ = c.display;
      out.context_ = ctx;
      out.renderer_ = r;
      out.version_ = version ? version : "unknown";
      out.platform_ = c.platform;
      return out;
    }
    if (preference == EglPreference::kHardware) break;
  }
  if (preference == EglPreference::kHardware) {
    return make_error(
        ErrorCode::kUnsupported, "egl",
        "no hardware OpenGL 4.5 renderer" + (tried.empty() ? std::string() : " (found only: " + tried + ")"));
  }
  return egl_error("no EGL display gives an OpenGL 4.5 core context");
}

EglContext::EglContext(EglContext&& other) noexcept { *this = std::move(other); }

EglContext& EglContext::operator=(EglContext&& other) noexcept {
  if (this != &other) {
    release();
    display_ = std::exchange(other.display_, EGL_NO_DISPLAY);
    context_ = std::exchange(other.context_, EGL_NO_CONTEXT);
    renderer_ = std::move(other.renderer_);
    version_ = std::move(other.version_);
    platform_ = std::move(other.platform_);
  }
  return *this;
}

EglContext::~EglContext() { release(); }

void EglContext::release() {
  if (context_ != EGL_NO_CONTEXT) {
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(display_, context_);
    context_ = EGL_NO_CONTEXT;
  }
  // The display is shared process-wide by EGL; terminating it would break other contexts.
  display_ = EGL_NO_DISPLAY;
}

Status EglContext::make_current() const {
  if (!eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, context_))
    return egl_error("eglMakeCurrent failed");
  return {};
}

void EglContext::release_current() const {
  if (context_ != EGL_NO_CONTEXT && eglGetCurrentContext() == context_)
    eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
}

bool is_software_renderer(const std::string& r) {
  return r.find("llvmpipe") != std::string::npos || r.find("softpipe") != std::string::npos ||
         r.find("swrast") != std::string::npos || r.find("SwiftShader") != std::string::npos;
}

bool EglContext::is_software() const { return is_software_renderer(renderer_); }

}  // namespace loam::gpu
