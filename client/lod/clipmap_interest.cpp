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

namespace {

// What every view holds besides its levels: mip-0 tiles near the camera, detail tiles nearer,
// and the coarsest mip everywhere.
void add_near_and_coarsest(std::set<TileCoord>& out, const WorldParams& world, const InterestConfig& c,
                           double cam_x, double cam_y, int32_t margin) {
  const int32_t mips = world.mip_count();
  const double mps = world.meters_per_sample;
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
}

// Level l's samples `level_rect` (grid spacing 2^l) as tiles of the mip it reads.
void add_level(std::set<TileCoord>& out, const WorldParams& world, int32_t l, const RectI& level_rect) {
  const int64_t s = int64_t(1) << l;
  const RectI e0{level_rect.x0 * s, level_rect.y0 * s, level_rect.x1 * s, level_rect.y1 * s};
  const int32_t m = std::min(l, world.mip_count() - 1);
  const int64_t sm = int64_t(1) << m;
  add_tiles(out, Layer::kCoarse, m,
            {floor_div(e0.x0, sm), floor_div(e0.y0, sm), ceil_div(e0.x1, sm), ceil_div(e0.y1, sm)},
            world.tile_range(m));
}

}  // namespace

std::set<TileCoord> clipmap_tiles(const WorldParams& world, const InterestConfig& c, double cam_x,
                                  double cam_y, int32_t margin) {
  std::set<TileCoord> out;
  const double mps = world.meters_per_sample;
  const auto placed = place_levels(c.n, c.levels, cam_x / mps, cam_y / mps);
  const int64_t side = int64_t(c.n) + 2 * int64_t(c.pad);
  for (const LevelPlacement& lp : placed) {
    const int64_t s = lp.spacing();
    const int64_t rx = floor_div(lp.origin_x, s) - c.pad - margin;
    const int64_t ry = floor_div(lp.origin_y, s) - c.pad - margin;
    add_level(out, world, lp.level, {rx, ry, rx + side + 2 * margin, ry + side + 2 * margin});
  }
  add_near_and_coarsest(out, world, c, cam_x, cam_y, margin);
  return out;
}

std::set<TileCoord> region_tiles(const WorldParams& world, const InterestConfig& c,
                                 std::span<const RectI> regions, double cam_x, double cam_y, int32_t margin) {
  std::set<TileCoord> out;
  for (size_t l = 0; l < regions.size(); ++l) {
    const RectI& r = regions[l];
    if (!r.empty())
      add_level(out, world, int32_t(l), {r.x0 - margin, r.y0 - margin, r.x1 + margin, r.y1 + margin});
  }
  add_near_and_coarsest(out, world, c, cam_x, cam_y, margin);
  return out;
}

ClipmapInterest::Delta ClipmapInterest::update(double cam_x, double cam_y, std::span<const RectI> regions) {
  Delta d;
  auto tiles = [&](int32_t margin) {
    return regions.empty() ? clipmap_tiles(world_, config_, cam_x, cam_y, margin)
                           : region_tiles(world_, config_, regions, cam_x, cam_y, margin);
  };
  const std::set<TileCoord> need = tiles(config_.margin);
  const std::set<TileCoord> keep = tiles(2 * config_.margin);
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
