#include "client/lod/clipmap_interest.h"

#include <cmath>

#include "client/lod/clipmap_mesh.h"

namespace loam::lod {

namespace {

void add_tiles(std::set<TileCoord>& out, Layer layer, int32_t mip, const RectI& samples, const RectI& range) {
  const RectI t = tiles_overlapping(samples).intersect(range);
  for (int64_t ty = t.y0; ty < t.y1; ++ty) {
    for (int64_t tx = t.x0; tx < t.x1; ++tx) out.insert({layer, uint8_t(mip), int32_t(tx), int32_t(ty)});
  }
}

// The square of samples (a grid `per_meter` samples per meter) within `radius_m` of a point.
RectI square(double cx, double cy, double radius_m, double per_meter) {
  return {int64_t(std::floor((cx - radius_m) * per_meter)), int64_t(std::floor((cy - radius_m) * per_meter)),
          int64_t(std::floor((cx + radius_m) * per_meter)) + 1,
          int64_t(std::floor((cy + radius_m) * per_meter)) + 1};
}

}  // namespace

std::set<TileCoord> clipmap_tiles(const WorldParams& world, const InterestConfig& c, double cam_x,
                                  double cam_y, int32_t margin) {
  std::set<TileCoord> out;
  const int32_t mips = world.mip_count();
  const double mps = world.meters_per_sample;
  const auto placed = place_levels(c.n, c.levels, cam_x / mps, cam_y / mps);
  const int64_t side = int64_t(c.n) + 2 * int64_t(c.pad);
  for (const LevelPlacement& lp : placed) {
    const int32_t l = lp.level;
    const int64_t s = lp.spacing();
    const int64_t rx = floor_div(lp.origin_x, s) - c.pad - margin;
    const int64_t ry = floor_div(lp.origin_y, s) - c.pad - margin;
    const RectI e0{rx * s, ry * s, (rx + side + 2 * margin) * s, (ry + side + 2 * margin) * s};
    const int32_t m = std::min(l, mips - 1);
    const int64_t sm = int64_t(1) << m;
    add_tiles(out, Layer::kCoarse, m,
              {floor_div(e0.x0, sm), floor_div(e0.y0, sm), ceil_div(e0.x1, sm), ceil_div(e0.y1, sm)},
              world.tile_range(m));
  }
  const double grow = double(margin) * mps;
  if (c.mip0_radius_m > 0) {
    add_tiles(out, Layer::kCoarse, 0, square(cam_x, cam_y, c.mip0_radius_m + grow, 1.0 / mps),
              world.tile_range(0));
  }
  if (c.detail_radius_m > 0) {
    const double per_m = double(world.detail_factor) / mps;
    add_tiles(out, Layer::kDetail, 0, square(cam_x, cam_y, c.detail_radius_m + grow, per_m),
              tiles_overlapping(world.detail_sample_rect()));
  }
  const RectI top = world.tile_range(mips - 1);
  for (int64_t ty = top.y0; ty < top.y1; ++ty) {
    for (int64_t tx = top.x0; tx < top.x1; ++tx)
      out.insert({Layer::kCoarse, uint8_t(mips - 1), int32_t(tx), int32_t(ty)});
  }
  return out;
}

ClipmapInterest::Delta ClipmapInterest::update(double cam_x, double cam_y) {
  Delta d;
  const std::set<TileCoord> need = clipmap_tiles(world_, config_, cam_x, cam_y, config_.margin);
  const std::set<TileCoord> keep = clipmap_tiles(world_, config_, cam_x, cam_y, 2 * config_.margin);
  for (const TileCoord& c : need) {
    if (subscribed_.insert(c).second) d.subscribe.push_back(c);
  }
  for (auto it = subscribed_.begin(); it != subscribed_.end();) {
    if (!keep.count(*it)) {
      d.unsubscribe.push_back(*it);
      it = subscribed_.erase(it);
    } else {
      ++it;
    }
  }
  return d;
}

}  // namespace loam::lod
