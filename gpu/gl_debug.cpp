#include "gpu/gl_debug.h"

#include <epoxy/gl.h>

#include <cstdio>

namespace loam::gpu {

#ifndef NDEBUG
namespace {
void GLAPIENTRY on_gl_debug(GLenum source, GLenum type, GLuint id, GLenum severity, GLsizei length,
                            const GLchar* message, const void* /*user*/) {
  // Notifications (buffer placement hints and the like) would drown real problems.
  if (severity == GL_DEBUG_SEVERITY_NOTIFICATION) return;
  std::fprintf(stderr, "GL debug: source 0x%x type 0x%x id %u severity 0x%x: %.*s\n", source, type, id,
               severity, int(length), message);
}
}  // namespace
#endif

void install_gl_debug_output() {
#ifndef NDEBUG
  glEnable(GL_DEBUG_OUTPUT);
  // Synchronous, so the message comes with the call that caused it.
  glEnable(GL_DEBUG_OUTPUT_SYNCHRONOUS);
  glDebugMessageCallback(on_gl_debug, nullptr);
#endif
}

}  // namespace loam::gpu
