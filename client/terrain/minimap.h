// The HUD's minimap, as the deformable-terrain paper's cache view: a square around the camera
// showing the clipmap levels' regions, the camera's frustum on the ground, the world's edge and
// every tile the client knows of, coloured by its state (client/terrain/tile_states.h).
// Pure logic: the layout in minimap pixels (x east, y along +gy, which is south in a DEM, as a
// map is drawn); the HUD draws it.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <vector>

#include "client/scene/camera.h"
#include "client/terrain/tile_states.h"
#include "protocol/geometry.h"
#include "protocol/world.h"

namespace loam::terrain {

// Colours as 8-bit RGBA packed little-endian (ImGui's IM_COL32 layout: r in the low byte).
constexpr uint32_t rgba(uint32_t r, uint32_t g, uint32_t b, uint32_t a = 255) {
  return r | (g << 8) | (b << 16) | (a << 24);
}
uint32_t tile_state_colour(TileState s);

struct MinimapInput {
  WorldParams world;
  std::vector<RectI> level_regions;  // per clipmap level, finest first, in mip-0 samples
  scene::Camera camera;
  double aspect = 16.0 / 9.0;  // the view's width / height
  const std::map<TileCoord, TileState>* tiles = nullptr;
};

struct MinimapRect {
  float x0 = 0, y0 = 0, x1 = 0, y1 = 0;  // pixels, clipped to the map
  uint32_t colour = 0;
};

struct Minimap {
  float size_px = 0;
  double meters_per_pixel = 0;
  std::vector<MinimapRect> coarse_tiles;  // filled, coarsest mip first (finer ones on top)
  std::vector<MinimapRect> detail_tiles;  // outlined
  std::vector<MinimapRect> levels;        // outlined, finest first
  std::optional<MinimapRect> world;  // the world's rect, unclipped (drawn clipped); none when off the map
  std::array<std::array<float, 2>, 3> frustum{};  // the camera, the far left and far right
};

// The map of `size_px` square: centred on the camera, spanning the outermost level's region
// plus a tenth (the whole world when no level is given).
Minimap layout_minimap(const MinimapInput& in, float size_px);

}  // namespace loam::terrain
