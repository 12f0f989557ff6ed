#include "client/terrain/height_source.h"

#include <algorithm>
#include <climits>
#include <cmath>
#include <vector>

namespace loam::terrain {

RectI level_samples_reading(const WorldParams& p, int32_t mip, const RectI& rect0) {
  const RectI w = p.sample_rect();
  const int64_t s = int64_t(1) << mip;
  // One axis: the indices [i0, i1) whose positions fall in [a, b).
  auto axis = [&](int64_t a, int64_t b, int64_t lo, int64_t hi) -> std::pair<int64_t, int64_t> {
    a = std::max(a, lo), b = std::min(b, hi);
    if (a >= b) return {0, 0};
    const int64_t first = ceil_div(lo, s), last = floor_div(hi - 1, s);
    if (first > last)
      return a == lo ? std::pair{-kFarSamples, kFarSamples} : std::pair<int64_t, int64_t>{0, 0};
    int64_t i0 = ceil_div(a, s), i1 = floor_div(b - 1, s) + 1;
    if (i0 >= i1) return {0, 0};
    if (i0 == first) i0 = -kFarSamples;
    if (i1 - 1 == last) i1 = kFarSamples;
    return {i0, i1};
  };
  const auto [x0, x1] = axis(rect0.x0, rect0.x1, w.x0, w.x1);
  const auto [y0, y1] = axis(rect0.y0, rect0.y1, w.y0, w.y1);
  if (x0 >= x1 || y0 >= y1) return {};
  return {x0, y0, x1, y1};
}

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
  const WorldParams& p = world_.params();
  const RectI w = p.sample_rect();
  const int64_t width = rect.width();
  const LevelAxis ax(mip, w.x0, w.x1), ay(mip, w.y0, w.y1);
  if (mip >= p.mip_count()) {
    size_t i = 0;
    for (int64_t y = rect.y0; y < rect.y1; ++y) {
      const int64_t gy = ay.position(y);
      for (int64_t x = rect.x0; x < rect.x1; ++x) out[i++] = world_.coarse(ax.position(x), gy);
    }
    return;
  }
  // From the mip's own tiles (World keeps them equal to decimation), not mip-0 samples at a
  // stride: a level far out would otherwise touch (2^mip)^2 times as many tiles.
  for (int64_t y = rect.y0; y < rect.y1; ++y) {
    const int64_t cy = ay.position(y) >> mip;
    const int32_t ty = int32_t(floor_div(cy, kTileSize));
    uint16_t* row = out.data() + (y - rect.y0) * width;
    int32_t held_tx = INT32_MIN;
    const uint16_t* tile = nullptr;
    for (int64_t x = rect.x0; x < rect.x1; ++x) {
      const int64_t cx = ax.position(x) >> mip;
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

std::array<double, 2> coarsest_height_range_m(const HeightSource& source) {
  const WorldParams& p = source.params();
  const int32_t mip = p.mip_count() - 1;
  const int64_t s = int64_t(1) << mip;
  const RectI w = p.sample_rect();
  const RectI m{ceil_div(w.x0, s), ceil_div(w.y0, s), ceil_div(w.x1, s), ceil_div(w.y1, s)};
  std::vector<uint16_t> samples(size_t(m.area()));
  source.read(mip, m, samples);
  const auto [lo, hi] = std::minmax_element(samples.begin(), samples.end());
  return {double(*lo) * p.meters_per_unit, double(*hi) * p.meters_per_unit};
}

double ground_height(const HeightSource& source, double x, double y) {
  const WorldParams& p = source.params();
  const double sx = x / p.meters_per_sample, sy = y / p.meters_per_sample;
  const int64_t x0 = int64_t(std::floor(sx)), y0 = int64_t(std::floor(sy));
  uint16_t q[4];
  source.read(0, {x0, y0, x0 + 2, y0 + 2}, q);
  const double fx = sx - double(x0), fy = sy - double(y0);
  const double v = (q[0] * (1 - fx) + q[1] * fx) * (1 - fy) + (q[2] * (1 - fx) + q[3] * fx) * fy;
  return p.height_offset + v * p.meters_per_unit;
}

}  // namespace loam::terrain
