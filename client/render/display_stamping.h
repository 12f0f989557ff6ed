// Where a viewer's display stamps what it is sent and what it predicts (`loam-client view
// --stamping`), and how `auto` is decided.
#pragma once

namespace loam::render {

// Where the display stamps: on the GPU tile cache (display_gpu_stamper.h), or on the CPU alone;
// kAuto picks the CPU only where it is measured faster: on a software rasterizer, where the
// optimized CPU kernel beats the GPU path at every radius (bench/results/gpu-stamps.md,
// llvmpipe: 0.021 against 0.024 ms at 1 m, 0.179 against 0.822 ms at 200 m), else the GPU.
enum class DisplayStamping { kGpu, kCpu, kAuto };

inline const char* to_string(DisplayStamping s) {
  return s == DisplayStamping::kGpu ? "gpu" : s == DisplayStamping::kCpu ? "cpu" : "auto";
}
// kAuto resolved for the GL renderer named `gl_renderer` (GL_RENDERER); the others as they are.
DisplayStamping resolve_stamping(DisplayStamping s, const char* gl_renderer);

}  // namespace loam::render
