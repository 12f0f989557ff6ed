#include "client/terrain/minimap.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace loam::terrain {

uint32_t tile_state_colour(TileState s) {
  switch (s) {
    case TileState::kHeld: return rgba(70, 190, 110, 150);
    case TileState::kPending: return rgba(240, 190, 40, 170);
    case TileState::kStale: return rgba(235, 70, 60, 190);
    case TileState::kEvicted: return rgba(130, 130, 140, 110);
  }
  return 0;
}

namespace {

struct MapFrame {
  double cx = 0, cy = 0, mpp = 1, half = 0;  // centre (meters), meters per pixel, half size (px)
  std::array<float, 2> px(double x, double y) const {
    return {float((x - cx) / mpp + half), float((y - cy) / mpp + half)};
  }
  // A rect in meters, clipped to the map; nullopt when it is not on it.
  std::optional<MinimapRect> rect(double x0, double y0, double x1, double y1, uint32_t colour) const {
    const auto a = px(x0, y0), b = px(x1, y1);
    const float size = float(2 * half);
    MinimapRect r{std::max(a[0], 0.f), std::max(a[1], 0.f), std::min(b[0], size), std::min(b[1], size),
                  colour};
    if (r.x0 >= r.x1 || r.y0 >= r.y1) return std::nullopt;
    return r;
  }
};

}  // namespace

Minimap layout_minimap(const MinimapInput& in, float size_px) {
  Minimap m;
  m.size_px = size_px;
  const double mps = in.world.meters_per_sample;
  const RectI w = in.world.sample_rect();
  double span = 0;
  if (!in.level_regions.empty()) {
    const RectI& outer = in.level_regions.back();
    span = 1.1 * double(std::max(outer.width(), outer.height())) * mps;
  } else {
    span = double(std::max(w.width(), w.height())) * mps;
  }
  MapFrame f;
  f.cx = in.camera.x;
  f.cy = in.camera.y;
  f.half = 0.5 * size_px;
  f.mpp = std::max(span, 1e-3) / std::max(double(size_px), 1.0);
  m.meters_per_pixel = f.mpp;

  if (in.tiles) {
    std::vector<std::pair<int, MinimapRect>> coarse;  // by mip, coarsest drawn first
    for (const auto& [c, s] : *in.tiles) {
      const bool detail = c.layer == Layer::kDetail;
      const double side = double(kTileSize) * double(int64_t(1) << c.mip) *
                          (detail ? in.world.detail_meters_per_sample() : mps);
      const auto r = f.rect(double(c.tx) * side, double(c.ty) * side, double(c.tx + 1) * side,
                            double(c.ty + 1) * side, tile_state_colour(s));
      if (!r) continue;
      if (detail) {
        m.detail_tiles.push_back(*r);
      } else {
        coarse.emplace_back(c.mip, *r);
      }
    }
    std::stable_sort(coarse.begin(), coarse.end(),
                     [](const auto& a, const auto& b) { return a.first > b.first; });
    for (const auto& [mip, r] : coarse) m.coarse_tiles.push_back(r);
  }
  // Levels: shades from white (finest) to blue (coarsest).
  const size_t n = in.level_regions.size();
  for (size_t l = 0; l < n; ++l) {
    const RectI& r = in.level_regions[l];
    const double t = n > 1 ? double(l) / double(n - 1) : 0.0;
    const uint32_t colour = rgba(uint32_t(255 - 155 * t), uint32_t(255 - 95 * t), 255, 230);
    if (auto mr =
            f.rect(double(r.x0) * mps, double(r.y0) * mps, double(r.x1) * mps, double(r.y1) * mps, colour))
      m.levels.push_back(*mr);
  }
  if (f.rect(double(w.x0) * mps, double(w.y0) * mps, double(w.x1) * mps, double(w.y1) * mps, 0)) {
    const auto a = f.px(double(w.x0) * mps, double(w.y0) * mps),
               b = f.px(double(w.x1) * mps, double(w.y1) * mps);
    m.world = MinimapRect{a[0], a[1], b[0], b[1], rgba(250, 250, 250, 255)};
  }

  // The frustum on the ground: the view's heading (the up hint when looking straight down)
  // and its horizontal half angle, out to the far plane or the map's edge.
  const scene::Camera& c = in.camera;
  double hx = c.fx, hy = c.fy;
  if (std::hypot(hx, hy) < 1e-6 * std::max(std::hypot(c.fx, c.fy, c.fz), 1e-12)) hx = c.ux, hy = c.uy;
  const double hl = std::hypot(hx, hy);
  if (hl > 0) hx /= hl, hy /= hl;
  const double half_fov =
      std::atan(std::tan(c.fov_y_degrees * std::numbers::pi / 360.0) * std::max(in.aspect, 1e-3));
  const double reach = std::min(c.far_m, 0.75 * span);
  const double len = reach / std::max(std::cos(half_fov), 0.05);
  auto ray = [&](double a) {
    const double ca = std::cos(a), sa = std::sin(a);
    // Rotating the heading by a in the map's frame (y along +gy).
    return f.px(c.x + len * (hx * ca - hy * sa), c.y + len * (hx * sa + hy * ca));
  };
  m.frustum = {f.px(c.x, c.y), ray(-half_fov), ray(half_fov)};
  return m;
}

}  // namespace loam::terrain
