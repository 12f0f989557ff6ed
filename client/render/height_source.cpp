#include "client/render/height_source.h"

#include <algorithm>
#include <climits>
#include <vector>

namespace loam::render {

void HeightSource::read_detail(const RectI&, std::span<int8_t> out) const {
  std::fill(out.begin(), out.end(), 0);
}

bool HeightSource::read_change(int32_t, const RectI&, std::span<float>) const { return false; }

bool WorldHeightSource::read_change(int32_t mip, const RectI& rect, std::span<float> out) const {
  if (!initial_) return false;
  std::vector<uint16_t> now(out.size()), before(out.size());
  read(mip, rect, now);
  WorldHeightSource(*initial_).read(mip, rect, before);
  const double mpu = world_.params().meters_per_unit;
  for (size_t i = 0; i < out.size(); ++i) out[i] = float((int32_t(now[i]) - int32_t(before[i])) * mpu);
  return true;
}

void WorldHeightSource::read(int32_t mip, const RectI& rect, std::span<uint16_t> out) const {
  if (mip == 0) {
    world_.read_coarse(rect, out);
    return;
  }
  // From the mip's own tiles (World keeps them equal to decimation), not mip-0 samples at a
  // stride: a level far out would otherwise touch (2^mip)^2 times as many tiles. A mip sample
  // outside the mip's tile range repeats the range's edge sample, as World's clamp rule gives.
  const WorldParams& p = world_.params();
  if (mip >= p.mip_count()) {
    const int64_t s = int64_t(1) << mip;
    size_t i = 0;
    for (int64_t y = rect.y0; y < rect.y1; ++y)
      for (int64_t x = rect.x0; x < rect.x1; ++x) out[i++] = world_.coarse(x * s, y * s);
    return;
  }
  const RectI tiles = p.tile_range(mip);
  const RectI span{tiles.x0 * kTileSize, tiles.y0 * kTileSize, tiles.x1 * kTileSize, tiles.y1 * kTileSize};
  const int64_t w = rect.width();
  for (int64_t y = rect.y0; y < rect.y1; ++y) {
    const int64_t cy = std::clamp(y, span.y0, span.y1 - 1);
    const int32_t ty = int32_t(floor_div(cy, kTileSize));
    uint16_t* row = out.data() + (y - rect.y0) * w;
    int32_t held_tx = INT32_MIN;
    const uint16_t* tile = nullptr;
    for (int64_t x = rect.x0; x < rect.x1; ++x) {
      const int64_t cx = std::clamp(x, span.x0, span.x1 - 1);
      const int32_t tx = int32_t(floor_div(cx, kTileSize));
      if (tx != held_tx) {
        tile = world_.coarse_tile(mip, tx, ty).data();
        held_tx = tx;
      }
      row[x - rect.x0] = tile[floor_mod(cy, kTileSize) * kTileSize + floor_mod(cx, kTileSize)];
    }
  }
}

void WorldHeightSource::read_detail(const RectI& rect, std::span<int8_t> out) const {
  world_.read_detail(rect, out);
}

}  // namespace loam::render
