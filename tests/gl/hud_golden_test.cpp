// Golden images of the viewer's HUD: the status panel, the minimap (clipmap levels, the
// frustum, tiles held, pending, stale and evicted) and the tool panel (a texture stamp picking
// one of the server's images by its preview; a volume-conserving crater), drawn by ImGui from
// made-up session numbers into an offscreen target and compared like the terrain goldens.
#include <gtest/gtest.h>

#if LOAM_HAVE_HUD
#include <backends/imgui_impl_opengl3.h>
#include <epoxy/gl.h>
#include <imgui.h>

#include <cmath>
#include <functional>

#include "client/render/offscreen_target.h"
#include "client/terrain/minimap.h"
#include "client/terrain/tile_states.h"
#include "client/view/hud.h"
#include "client/view/stamp_previews.h"
#include "gl_test_context.h"
#include "golden_image.h"

namespace loam::view {
namespace {

// A world of 64 x 32 tiles at 2 m (32.8 x 16.4 km), six levels of n = 127 around a camera
// near its centre, looking north-east.
terrain::MinimapInput sample_map(const terrain::TileStates& tiles) {
  terrain::MinimapInput in;
  in.world.meters_per_sample = 2.0;
  in.world.tiles_x = 64;
  in.world.tiles_y = 32;
  in.camera = scene::look_at(16000, 9000, 300, 16600, 8500, 250);
  in.camera.far_m = 8000;
  const int64_t cx = 8000, cy = 4500;  // mip-0 samples
  for (int l = 0; l < 6; ++l) {
    const int64_t half = int64_t(68) << l, snap = int64_t(2) << l;
    const int64_t x0 = (cx - half) / snap * snap, y0 = (cy - half) / snap * snap;
    in.level_regions.push_back({x0, y0, x0 + (int64_t(137) << l), y0 + (int64_t(137) << l)});
  }
  in.aspect = 16.0 / 9.0;
  in.tiles = &tiles.tiles();
  return in;
}

// Tiles of mips 0..3 around the camera: held, some pending at the edge of each mip's ring, two
// stale, and a column that was held and is now evicted.
terrain::TileStates sample_tiles() {
  std::vector<TileCoord> wanted, held, behind, before;
  for (uint8_t mip = 0; mip < 4; ++mip) {
    const double side = 512.0 * double(1 << mip);
    const int32_t tx = int32_t(16000 / side), ty = int32_t(9000 / side);
    for (int32_t y = ty - 3; y <= ty + 3; ++y) {
      for (int32_t x = tx - 3; x <= tx + 3; ++x) {
        if (x < 0 || y < 0 || x >= (64 >> mip) || y >= (32 >> mip)) continue;
        const TileCoord c{Layer::kCoarse, mip, x, y};
        wanted.push_back(c);
        const bool edge = std::abs(x - tx) == 3 || std::abs(y - ty) == 3;
        if (!(edge && (x + 2 * y) % 3 == 0)) held.push_back(c);
      }
    }
  }
  behind = {{Layer::kCoarse, 0, 31, 17}, {Layer::kCoarse, 0, 32, 16}};
  for (int32_t y = 14; y <= 20; ++y) before.push_back({Layer::kCoarse, 0, 27, y});
  for (int32_t d = 0; d < 4; ++d) {
    const TileCoord c{Layer::kDetail, 0, 4 * 31 + d, 4 * 17 + 2};
    wanted.push_back(c);
    held.push_back(c);
  }
  terrain::TileStates states;
  std::vector<TileCoord> held_before = held;
  held_before.insert(held_before.end(), before.begin(), before.end());
  states.update(held_before, held_before, {}, 0.0);
  states.update(wanted, held, behind, 1.0);
  return states;
}

// Three registered images: a ring, a ramp and a boot print.
TextureRegistry sample_images() {
  TextureRegistry r;
  auto add = [&](int32_t w, int32_t h, const std::function<double(double, double)>& f) {
    std::vector<uint16_t> px(size_t(w) * size_t(h));
    for (int32_t y = 0; y < h; ++y)
      for (int32_t x = 0; x < w; ++x)
        px[size_t(y) * size_t(w) + size_t(x)] =
            uint16_t(std::clamp(f((x + 0.5) / w * 2 - 1, (y + 0.5) / h * 2 - 1), 0.0, 1.0) * 65535.0);
    EXPECT_TRUE(r.add(w, h, px).ok());
  };
  add(96, 96, [](double u, double v) { return std::exp(-std::pow((std::hypot(u, v) - 0.6) / 0.15, 2)); });
  add(128, 64, [](double u, double) { return 0.5 + 0.5 * u; });
  add(64, 128, [](double u, double v) {
    const double heel = std::hypot(u / 0.5, (v - 0.5) / 0.35), sole = std::hypot(u / 0.6, (v + 0.25) / 0.55);
    return std::min(heel, sole) < 1.0 ? 1.0 : 0.0;
  });
  return r;
}

render::ViewerStats sample_session() {
  render::ViewerStats v;
  v.tiles_subscribed = 212, v.tiles_held = 187, v.regions = 341, v.events_applied = 96;
  v.hash_checks = 40;
  v.overlay = 2;
  v.display.events_stamped = 96, v.display.predicted = 12, v.display.corrections = 1;
  v.gpu_terrain_bytes = 41u << 20, v.gpu_pages_resident = 24, v.cpu_terrain_bytes = 29u << 20;
  v.rtt_ms = 23.4, v.bytes_in_per_s = 83.5 * 1024, v.budget_bytes_per_s = 128 * 1024;
  v.server_tick_p50_us = 310, v.server_tick_p99_us = 1240, v.server_clients = 5;
  return v;
}

class HudGolden : public ::testing::Test {
 protected:
  void draw_and_compare(const std::string& name, int32_t width, int32_t height,
                        const std::function<void()>& draw) {
    LOAM_REQUIRE_IDIFF();
    auto target = render::OffscreenTarget::create(width, height);
    ASSERT_TRUE(target.ok());
    ImGui::CreateContext();
    ImGuiIO& io = ImGui::GetIO();
    io.IniFilename = nullptr;
    io.DisplaySize = ImVec2(float(width), float(height));
    io.DeltaTime = 1.0f / 60.0f;
    ASSERT_TRUE(ImGui_ImplOpenGL3_Init("#version 450 core"));
    // Auto-sized windows take their size on the second frame: draw three, keep the last.
    for (int frame = 0; frame < 3; ++frame) {
      ImGui_ImplOpenGL3_NewFrame();
      ImGui::NewFrame();
      draw();
      ImGui::Render();
      target->begin(0.22f, 0.27f, 0.22f, 1.0f);
      ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    }
    const std::vector<uint8_t> rgba = target->read_rgba();
    ImGui_ImplOpenGL3_Shutdown();
    ImGui::DestroyContext();
    render::test::compare_with_golden(name, width, height, rgba);
  }
};

TEST_F(HudGolden, StatusMinimapAndATextureToolPickingAServerImage) {
  LOAM_REQUIRE_GL();
  const terrain::TileStates tiles = sample_tiles();
  const terrain::Minimap map = terrain::layout_minimap(sample_map(tiles), 240.0f);
  const TextureRegistry images = sample_images();
  StampPreviews previews;
  previews.update(images);
  std::vector<wire::StampImageListEntry> listed;
  for (const StampTexture* t : images.all())
    listed.push_back({t->id, uint32_t(t->width), uint32_t(t->height)});
  listed.push_back({0x1234, 1024, 1024});  // registered, too big to serve: stamped by id alone
  controls::StampTool tool;
  tool.select(controls::Tool::kCrater);
  tool.set_kind(StampKind::kTexture);
  tool.texture_id = images.all()[1]->id;
  HudStatus status;
  status.renderer = "llvmpipe (LLVM 15.0.6, 256 bits)";
  status.frame_ms = 16.7, status.triangles = 386000, status.draw_calls = 9;
  status.camera_x = 16000, status.camera_y = 9000, status.camera_z = 300, status.speed_mps = 40;
  status.session = sample_session();
  draw_and_compare("hud_texture_tool", 960, 600, [&] {
    draw_status_panel(status);
    draw_minimap_panel(map, tiles.counts());
    draw_tool_panel(tool, listed, previews);
  });
}

TEST_F(HudGolden, AVolumeConservingCraterInTheToolPanel) {
  LOAM_REQUIRE_GL();
  controls::StampTool tool;
  tool.radius_m = 24;
  tool.select(controls::Tool::kCrater);
  tool.volume_conserving = true;
  tool.rotation_degrees = 45;
  StampPreviews previews;
  draw_and_compare("hud_crater_tool", 480, 320, [&] { draw_tool_panel(tool, {}, previews); });
}

}  // namespace
}  // namespace loam::view
#endif
