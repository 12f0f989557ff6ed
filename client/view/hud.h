// The viewer's HUD, drawn with ImGui between NewFrame and Render: the status panel (frame,
// session: round trip, bytes/s against the client's budget, the server's tick; tiles, events,
// memory), the minimap (client/terrain/minimap.h) with its legend, and the tool panel, which edits
// every field of the stamp tool for every kind (texture stamps pick one of the server's
// registered images by its preview; craters can conserve volume). The panels take plain data,
// so a test draws them from made-up numbers and compares the picture.
#pragma once

#include <span>
#include <string>

#include "client/controls/stamp_tool.h"
#include "client/render/viewer_session.h"
#include "client/terrain/minimap.h"
#include "client/terrain/tile_states.h"
#include "client/view/stamp_previews.h"
#include "protocol/wire/messages.h"

namespace loam::view {

struct HudStatus {
  std::string renderer;
  double frame_ms = 0;
  int64_t triangles = 0;
  int32_t draw_calls = 0;
  double lod_budget_px = 0;  // the error-driven clipmap's budget met (0: classic)
  double camera_x = 0, camera_y = 0, camera_z = 0, speed_mps = 0;
  bool walking = false;
  render::ViewerStats session;
};

void draw_status_panel(const HudStatus& s);
// The minimap at the window's top right.
void draw_minimap_panel(const terrain::Minimap& map, const terrain::TileStateCounts& counts);
// The tool panel at the window's bottom left; true when the user changed the tool.
bool draw_tool_panel(controls::StampTool& tool, std::span<const wire::StampImageListEntry> images,
                     const StampPreviews& previews);

}  // namespace loam::view
