// The windowed viewer's pieces that its frame loop (viewer_app.cpp) and the window tests
// share: where a window starts on the session's world and the scales of its controls there
// (render/start_view.h), the HUD drawn over a frame (an ImGui context on the window, made and
// destroyed with a HudOverlay), and what the window's framebuffer shows. The GL context of the
// window must be current for everything here that draws or reads pixels.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "client/controls/fly_camera.h"
#include "client/controls/stamp_tool.h"
#include "client/render/viewer_session.h"
#include "client/scene/start_view.h"
#include "client/terrain/minimap.h"
#include "client/terrain/tile_states.h"
#include "client/view/hud.h"
#include "client/view/stamp_previews.h"

struct GLFWwindow;

namespace loam::view {

// The ground the session displays (m) at a world point: what the fly camera keeps above and
// the start view clears.
scene::GroundFn display_ground(render::ViewerSession& s);

// The window's first camera on the session's world: the start view's eye (east of the
// world's centre, looking at it over the ground the coarsest tiles show), flying at the
// world's speed.
controls::FlyCamera window_start(render::ViewerSession& s, const scene::ViewScale& scale);
// The camera a window draws from `fly`: 60 degrees, its far plane past both the renderer's
// view distance and the start view's horizon; a walker's eye sees from 10 cm.
scene::Camera window_camera(const controls::FlyCamera& fly, double view_distance_m,
                            const scene::ViewScale& scale, bool walking);
// The stamp tool sized for the world: its radius range and a radius visible from the orbit.
void scale_tool(controls::StampTool& tool, const scene::ViewScale& scale);

// The minimap's input from the session: the levels' regions in mip-0 samples, the camera.
terrain::MinimapInput minimap_input(render::ViewerSession& s, const scene::Camera& cam, double aspect,
                                    const terrain::TileStates& tiles);

// The HUD over a window: status, minimap and tool panel, drawn by ImGui with its GLFW and
// OpenGL 3 backends. One per window; input callbacks are chained to ImGui's.
class HudOverlay {
 public:
  explicit HudOverlay(GLFWwindow* window);
  ~HudOverlay();
  HudOverlay(const HudOverlay&) = delete;
  HudOverlay& operator=(const HudOverlay&) = delete;

  bool wants_keyboard() const;  // a panel has the keyboard (typing in a field)
  bool wants_mouse() const;     // the cursor is over a panel
  // Draws the panels over the current framebuffer; true when the user changed the tool.
  bool draw(const HudStatus& status, const terrain::Minimap& map, const terrain::TileStateCounts& counts,
            controls::StampTool& tool, std::span<const wire::StampImageListEntry> images,
            const StampPreviews& previews);
};

// Starts a frame in the window's default framebuffer (w x h): viewport, the sky's colour,
// reversed depth cleared to the background.
void begin_window_frame(int32_t w, int32_t h);

// The window's default framebuffer (w x h): RGBA8, top row first; and the fraction of its
// pixels that show terrain (a depth other than the background's) after the scene was drawn.
std::vector<uint8_t> read_window_rgba(int32_t w, int32_t h);
double window_terrain_fraction(int32_t w, int32_t h);

}  // namespace loam::view
