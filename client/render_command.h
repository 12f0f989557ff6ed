// `loam-client render`: the terrain of a DEM, a snapshot, a live session or the embedded
// default, drawn headless (EGL) by the viewer's renderer, one frame or a scripted camera
// path to PNGs, with frame time, triangles and draw calls printed.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "protocol/wire/messages.h"
#include "transport/tls_context.h"

namespace loam::render {

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
