// `loam-client view`: the viewer. In a window (GLFW): fly over a live session's terrain, click
// to deform it (the stamp shows at once, settles when the server confirms it), with a HUD of
// frame time, triangles, tiles, events, overlay, corrections and hash checks. Headless (EGL,
// for machines without a display, and the main job on them): the camera orbits, a stamp is
// made at the view's centre every few seconds, screenshots are written and the same numbers
// are printed once a second.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "client/render/clipmap_renderer.h"
#include "client/render/display_stamping.h"
#include "client/render/error_clipmap_renderer.h"
#include "client/render/lod_scheme.h"
#include "client/render/viewer_session.h"
#include "protocol/wire/messages.h"
#include "transport/tls_context.h"

namespace loam::view {

struct ViewerAppOptions {
  std::string host = "127.0.0.1";
  uint16_t port = 7878;
  std::string name = "viewer";
  std::optional<wire::AccessToken> token;  // needed where the server has tokens
  transport::TlsClientOptions tls;
  // The session's defaults (render/viewer_session.h).
  render::LodScheme lod = render::ViewerOptions{}.lod;
  render::RendererConfig renderer;  // the classic clipmap's, and the view distance
  render::ErrorClipmapConfig error_clipmap =
      render::viewer_error_clipmap_defaults();  // the error-driven clipmap's
  render::DisplayStamping stamping = render::DisplayStamping::kAuto;
  int32_t gpu_cache_mb = 128;  // the display's GPU tile cache (coarse pages; detail pages take half)
  int32_t width = 1280, height = 720;
  bool headless = false;                  // EGL + offscreen instead of a window
  double seconds = 0;                     // stop after this long (0: until the window closes; headless: 30)
  double stamp_every_s = 0;               // headless: a stamp at the view's centre this often (0: none)
  double fly_mps = 0;                     // headless: fly a loop at this speed instead of orbiting (0: orbit)
  double screenshot_every_s = 0;          // headless: write a PNG this often (0: only at the end)
  std::string screenshot = "viewer.png";  // file name; numbered (viewer_0001.png) when several
  bool walk = false;                      // start in walk mode (window: G toggles; headless: walk the centre)
  double dig_under_s = 0;  // headless walk: dig a crater under the walker at this time (0: never)
  bool vsync = true;
  bool hud = true;  // window: start with the HUD shown (F1 toggles)
};

// Runs the viewer; returns the process exit code (0, or 1 when it could not start or the
// session failed, 3 when a hash mismatch or a GPU/CPU divergence was seen).
int run_viewer(const ViewerAppOptions& options);

}  // namespace loam::view
