#include "client/render/display_stamping.h"

#include "gpu/egl_context.h"

namespace loam::render {

DisplayStamping resolve_stamping(DisplayStamping s, const char* gl_renderer) {
  if (s != DisplayStamping::kAuto) return s;
  return gl_renderer != nullptr && gpu::is_software_renderer(gl_renderer) ? DisplayStamping::kCpu
                                                                          : DisplayStamping::kGpu;
}

}  // namespace loam::render
