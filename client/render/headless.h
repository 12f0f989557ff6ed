// Headless rendering: an offscreen framebuffer (RGBA8 colour, 32-bit float depth) to render
// the clipmap into, pixel and depth readback in top-down row order, PNG output through
// OpenImageIO, and `loam-client render`: one frame or a scripted camera path to PNGs with
// frame time, triangles and draw calls printed. Needs the GL context current.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "client/render/clipmap_renderer.h"
#include "client/render/viewer_session.h"
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

struct RenderCommandOptions {
  std::string dem;                         // empty: the embedded default terrain
  std::string snapshot;                    // a snapshot folder, or a data folder (its newest snapshot)
  std::string server;                      // host:port: render a live session instead (its confirmed tiles)
  std::optional<wire::AccessToken> token;  // for --server where it has tokens
  transport::TlsClientOptions tls;
  std::array<double, 3> camera{1024.0, 1700.0, 300.0};
  std::array<double, 3> look{1024.0, 800.0, 60.0};
  int32_t width = 1280, height = 720;
  std::string out = "render.png";
  std::string path;  // a file of "x y z tx ty tz" lines: one PNG per line (out_NNNN.png)
  bool morph = true;
  int32_t n = 127;
  int32_t levels = 0;
  double view_distance = 4000.0;
  double fov_y_degrees = 60.0;
};

// Runs `loam-client render`; returns the process exit code. Prints one line per frame.
int run_render_command(const RenderCommandOptions& options);

}  // namespace loam::render
