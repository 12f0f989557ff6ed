#include "client/view/viewer_window.h"

#include <epoxy/gl.h>
// After epoxy: GLFW must not pull in a second set of GL declarations.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <imgui.h>

#include <algorithm>

#include "client/render/reversed_depth.h"
#include "client/scene/camera.h"
#include "client/terrain/height_source.h"

namespace loam::view {

scene::GroundFn display_ground(render::ViewerSession& s) {
  const terrain::HeightSource& source = s.display();
  return [&source](double x, double y) { return terrain::ground_height(source, x, y); };
}

controls::FlyCamera window_start(render::ViewerSession& s, const scene::ViewScale& scale) {
  const scene::Camera c = scene::orbit_view(scale, 0.0, display_ground(s));
  controls::FlyCamera fly =
      controls::FlyCamera::looking_at(c.x, c.y, c.z, c.x + c.fx, c.y + c.fy, c.z + c.fz);
  fly.set_speed(scale.fly_speed_mps);
  return fly;
}

scene::Camera window_camera(const controls::FlyCamera& fly, double view_distance_m,
                            const scene::ViewScale& scale, bool walking) {
  scene::Camera cam = fly.camera(60.0, std::max(4.0 * view_distance_m, scale.far_m));
  if (walking) cam.near_m = 0.1;
  return cam;
}

void scale_tool(controls::StampTool& tool, const scene::ViewScale& scale) {
  tool.min_radius_m = scale.tool_min_radius_m;
  tool.max_radius_m = scale.tool_max_radius_m;
  tool.set_radius(scale.tool_radius_m);
}

terrain::MinimapInput minimap_input(render::ViewerSession& s, const scene::Camera& cam, double aspect,
                                    const terrain::TileStates& tiles) {
  terrain::MinimapInput in;
  in.world = s.client().welcome().world;
  for (int32_t l = 0; l < s.levels(); ++l) {
    const RectI r = s.level_region(l);
    in.level_regions.push_back({r.x0 << l, r.y0 << l, r.x1 << l, r.y1 << l});
  }
  in.camera = cam;
  in.aspect = aspect;
  in.tiles = &tiles.tiles();
  return in;
}

HudOverlay::HudOverlay(GLFWwindow* window) {
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  ImGui_ImplGlfw_InitForOpenGL(window, true);
  ImGui_ImplOpenGL3_Init("#version 450 core");
}

HudOverlay::~HudOverlay() {
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
}

bool HudOverlay::wants_keyboard() const { return ImGui::GetIO().WantCaptureKeyboard; }
bool HudOverlay::wants_mouse() const { return ImGui::GetIO().WantCaptureMouse; }

bool HudOverlay::draw(const HudStatus& status, const terrain::Minimap& map,
                      const terrain::TileStateCounts& counts, controls::StampTool& tool,
                      std::span<const wire::StampImageListEntry> images, const StampPreviews& previews) {
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
  draw_status_panel(status);
  draw_minimap_panel(map, counts);
  const bool changed = draw_tool_panel(tool, images, previews);
  ImGui::Render();
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  return changed;
}

void begin_window_frame(int32_t w, int32_t h) {
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glViewport(0, 0, w, h);
  glClearColor(0.50f, 0.60f, 0.75f, 1.0f);
  render::clear_depth_reversed();
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
}

std::vector<uint8_t> read_window_rgba(int32_t w, int32_t h) {
  std::vector<uint8_t> rgba(size_t(w) * size_t(h) * 4), flipped(rgba.size());
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadBuffer(GL_BACK);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_UNSIGNED_BYTE, rgba.data());
  const size_t row = size_t(w) * 4;
  for (int32_t y = 0; y < h; ++y)
    std::copy_n(rgba.begin() + ptrdiff_t(size_t(h - 1 - y) * row), row,
                flipped.begin() + ptrdiff_t(size_t(y) * row));
  return flipped;
}

double window_terrain_fraction(int32_t w, int32_t h) {
  if (w <= 0 || h <= 0) return 0.0;
  std::vector<float> depth(size_t(w) * size_t(h));
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  glReadPixels(0, 0, w, h, GL_DEPTH_COMPONENT, GL_FLOAT, depth.data());
  const auto terrain =
      std::count_if(depth.begin(), depth.end(), [](float d) { return d != scene::kBackgroundDepth; });
  return double(terrain) / double(depth.size());
}

}  // namespace loam::view
