// The windowed viewer's first frames on every kind of world, in a real GLFW window (under
// xvfb-run in scripts/test.sh; skipped without a display elsewhere, failed in CI): the main
// job's refined 131 km world, the embedded crop, and a DEM imported as a tile pack (Tennessee
// ridges at 3", 403 x 344 samples, from ../shared/data). Each starts where the viewer starts
// (render/start_view.h through view/viewer_window.h), settles, and must show terrain over most
// of the view (read from the window's depth buffer); its picture with the HUD off and on is
// compared, at half size, with goldens (tests/golden/images/window_*.png, approved with
// scripts/approve-goldens.sh). The HUD's session numbers that vary run to run (round trip,
// rates, tick times) are fixed, as in hud_golden_test.cpp. Pins the window that showed only sky
// on the refined world: its camera stood 59 km south of the centre, 33 km up.
#include <gtest/gtest.h>

#if LOAM_HAVE_VIEWER_WINDOW
#include <epoxy/gl.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <cstdlib>
#include <filesystem>

#include "client/render/viewer_session.h"
#include "client/view/viewer_window.h"
#include "dem/pack_import.h"
#include "gl/gl_test_context.h"
#include "gl/golden_image.h"
#include "gpu/glfw_context.h"
#include "integration/integration_util.h"
#include "integration/server_process.h"

namespace loam::test {
namespace {

using namespace std::chrono_literals;

// Wide enough for the HUD's panels side by side, as on a desktop.
constexpr int32_t kWidth = 960, kHeight = 540;

bool have_display() { return std::getenv("DISPLAY") != nullptr; }

// A window's GLX context, and no EGL test context in the process (Mesa refuses to make a GLX
// context current beside one: X_GLXMakeCurrent BadAccess).
#define LOAM_REQUIRE_WINDOW()                                                   \
  do {                                                                          \
    if (!have_display()) {                                                      \
      if (::loam::gpu::test::running_in_ci()) FAIL() << "no DISPLAY in CI";     \
      GTEST_SKIP() << "no DISPLAY (scripts/test.sh runs ctest under xvfb-run)"; \
    }                                                                           \
  } while (0)

// The window's picture at half size (2 x 2 box filter): the goldens stay small, and a HUD's
// letters still change the picture where they change.
std::vector<uint8_t> half_size(const std::vector<uint8_t>& rgba, int32_t w, int32_t h) {
  std::vector<uint8_t> out(size_t(w / 2) * size_t(h / 2) * 4);
  for (int32_t y = 0; y < h / 2; ++y) {
    for (int32_t x = 0; x < w / 2; ++x) {
      for (int32_t c = 0; c < 4; ++c) {
        int sum = 2;  // rounds to nearest
        for (int32_t dy = 0; dy < 2; ++dy)
          for (int32_t dx = 0; dx < 2; ++dx)
            sum += rgba[(size_t(2 * y + dy) * size_t(w) + size_t(2 * x + dx)) * 4 + size_t(c)];
        out[(size_t(y) * size_t(w / 2) + size_t(x)) * 4 + size_t(c)] = uint8_t(sum / 4);
      }
    }
  }
  return out;
}

void compare_window(const std::string& golden, int32_t w, int32_t h) {
  render::test::compare_with_golden(golden, w / 2, h / 2, half_size(view::read_window_rgba(w, h), w, h));
}

// The HUD's status as the viewer fills it, with the numbers that vary between runs fixed.
view::HudStatus fixed_status(render::ViewerSession& s, const controls::FlyCamera& fly) {
  view::HudStatus status;
  status.renderer = "llvmpipe";
  status.frame_ms = 16.7;
  status.triangles = 123456;
  status.draw_calls = 42;
  status.lod_budget_px = 1.0;
  status.camera_x = fly.x(), status.camera_y = fly.y(), status.camera_z = fly.z();
  status.speed_mps = fly.speed();
  status.session.tiles_held = s.stats().tiles_held;
  status.session.tiles_subscribed = s.stats().tiles_subscribed;
  status.session.rtt_ms = 0.4;
  status.session.bytes_in_per_s = 2048;
  status.session.budget_bytes_per_s = 1 << 20;
  status.session.server_tick_p50_us = 250;
  status.session.server_tick_p99_us = 900;
  status.session.server_clients = 1;
  return status;
}

// A window on the session at `port`, from the viewer's start: settles, checks the terrain's
// share of the view and compares the picture with and without the HUD with `name`'s goldens.
void window_on(uint16_t port, const std::string& name) {
  auto window = gpu::GlfwContext::create(
      {.width = kWidth, .height = kHeight, .title = "loam window test", .vsync = false, .visible = true});
  ASSERT_TRUE(window.ok()) << window.error().describe();
  render::ViewerOptions options;  // the viewer's renderer defaults, its view distance the world's
  options.renderer.view_distance = 0;
  options.name = "window-" + name;
  auto session = render::ViewerSession::connect("127.0.0.1", port, options);
  ASSERT_TRUE(session.ok()) << session.error().describe();
  render::ViewerSession& s = **session;
  const scene::ViewScale scale = scene::view_scale(s.client().welcome().world);
  const controls::FlyCamera fly = view::window_start(s, scale);
  const scene::Camera cam = view::window_camera(fly, s.view_distance_m(), scale, false);
  ASSERT_TRUE(s.wait_settled(cam, 120s)) << name << ": the start view's tiles did not all arrive";
  int w = 0, h = 0;
  glfwGetFramebufferSize(window->window(), &w, &h);
  ASSERT_EQ(w, kWidth);
  ASSERT_EQ(h, kHeight);

  view::begin_window_frame(w, h);
  const render::FrameStats f = s.render(cam, w, h);
  const double terrain = view::window_terrain_fraction(w, h);
  std::printf("%s: camera at %.0f, %.0f, %.0f m, %lld triangles, terrain covers %.1f%% of the view\n",
              name.c_str(), fly.x(), fly.y(), fly.z(), (long long)f.triangles, 100.0 * terrain);
  EXPECT_GT(f.triangles, 0);
  EXPECT_GT(terrain, 0.5) << name << ": the window shows mostly sky";
  compare_window("window_" + name + "_hud_off", w, h);

  // The HUD as the viewer draws it; ImGui sizes its panels on their first frames.
  view::HudOverlay overlay(window->window());
  controls::StampTool tool;
  tool.select(controls::Tool::kCrater);
  view::scale_tool(tool, scale);
  terrain::TileStates tiles;
  const client::ConfirmedStore& store = s.client().store();
  tiles.update(store.wanted(), store.held(), store.tiles_behind(), 0.0);
  view::StampPreviews previews;
  for (int frame = 0; frame < 3; ++frame) {
    view::begin_window_frame(w, h);
    s.render(cam, w, h);
    overlay.draw(fixed_status(s, fly),
                 terrain::layout_minimap(view::minimap_input(s, cam, double(w) / double(h), tiles), 240.0f),
                 tiles.counts(), tool, s.client().stamp_images(), previews);
    if (frame < 2) window->swap_buffers();
  }
  compare_window("window_" + name + "_hud_on", w, h);
}

TEST(ViewerWindow, OnTheRefinedWorldTheFirstFramesShowTerrainNotSky) {
  LOAM_REQUIRE_WINDOW();
  LOAM_REQUIRE_IDIFF();
  ServerProcess server;
  ASSERT_TRUE(server.start(temp_data_dir("refined"), {"--terrain", "refined", "--cache-mb", "64"}))
      << server.log();
  window_on(server.port(), "refined");
}

TEST(ViewerWindow, OnTheCropTheFirstFramesShowTerrain) {
  LOAM_REQUIRE_WINDOW();
  LOAM_REQUIRE_IDIFF();
  ServerProcess server;
  ASSERT_TRUE(server.start(temp_data_dir("crop"))) << server.log();
  window_on(server.port(), "crop");
}

TEST(ViewerWindow, OnADemPackOfAnotherSizeAndSpacingTheFirstFramesShowTerrain) {
  LOAM_REQUIRE_WINDOW();
  LOAM_REQUIRE_IDIFF();
  const std::filesystem::path dem = std::filesystem::path(LOAM_SHARED_DATA_DIR) / "jacksboro_3s_403x344.png";
  if (!std::filesystem::exists(dem)) {
    if (gpu::test::running_in_ci()) FAIL() << dem << " is missing: CI runs with ../shared beside the clone";
    GTEST_SKIP() << dem << " is missing (../shared/data)";
  }
  const std::string dir = temp_data_dir("pack");
  const std::string pack = dir + "/jacksboro.loampack";
  auto imported = import_dem_to_pack(dem.string(), pack);
  ASSERT_TRUE(imported.ok()) << imported.error().describe();
  ServerProcess server;
  ASSERT_TRUE(server.start(dir + "/data", {"--dem", pack})) << server.log();
  window_on(server.port(), "pack");
}

}  // namespace
}  // namespace loam::test
#endif
