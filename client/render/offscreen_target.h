// Headless rendering: an offscreen framebuffer (RGBA8 colour, 32-bit float depth) to render
// the terrain into, pixel and depth readback in top-down row order, and PNG output
// (dem/image_file.h). Needs the GL context current.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "gpu/gl_handle.h"
#include "protocol/result.h"

namespace loam::render {

class OffscreenTarget {
 public:
  static Result<OffscreenTarget> create(int32_t width, int32_t height);
  // Binds the framebuffer and clears colour to `rgba` (alpha 0 marks background) and depth.
  void begin(float r, float g, float b, float a) const;
  // RGBA8, row 0 at the top of the image.
  std::vector<uint8_t> read_rgba() const;
  // Window-space depth in [0, 1], row 0 at the top.
  std::vector<float> read_depth() const;
  int32_t width() const { return width_; }
  int32_t height() const { return height_; }

 private:
  OffscreenTarget() = default;
  int32_t width_ = 0, height_ = 0;
  gpu::GlTexture color_, depth_;
  gpu::GlFramebuffer fbo_;
};

// Writes 8-bit RGB (the alpha channel dropped) or RGBA as PNG.
Status write_png(const std::string& path, int32_t width, int32_t height, const std::vector<uint8_t>& rgba,
                 bool keep_alpha = false);

}  // namespace loam::render
