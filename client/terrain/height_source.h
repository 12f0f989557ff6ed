// What the clipmap levels read: a HeightSource answers mip samples of any rect (past the
// world's edge, by the rule of LevelAxis), detail offsets, and how the terrain
// changed against the session's initial state. No GL: the renderer, the display terrain and
// tests share it.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <span>

#include "protocol/geometry.h"
#include "protocol/world.h"

namespace loam::terrain {

// The mip-0 sample that mip-`mip` sample i reads along one axis of the world's sample range
// [lo, hi): i * 2^mip inside the world; past an edge, the mip's first or last sample inside.
// Every position is a multiple of 2^mip, which every mip up to `mip` holds by decimation: a
// client holding coarse tiles alone reads exactly what the whole world gives, edges included.
// (Where no multiple lies inside, which only a level coarser than the world meets: lo.)
class LevelAxis {
 public:
  LevelAxis(int32_t mip, int64_t lo, int64_t hi)
      : lo_(lo),
        first_(ceil_div(lo, int64_t(1) << mip)),
        last_(floor_div(hi - 1, int64_t(1) << mip)),
        mip_(mip) {}
  int64_t position(int64_t i) const { return first_ > last_ ? lo_ : std::clamp(i, first_, last_) << mip_; }

 private:
  int64_t lo_, first_, last_;
  int32_t mip_;
};
// The mip-`mip` samples whose positions fall in mip-0 rect `rect0` (rows and columns past the
// world's edge reach far out, kFarSamples, where rect0 holds the edge's position): what an
// edit of `rect0` changes in a level.
RectI level_samples_reading(const WorldParams& p, int32_t mip, const RectI& rect0);
inline constexpr int64_t kFarSamples = int64_t(1) << 40;

// Where level textures get their samples: the server's world, a local DEM, or the
// client's confirmed store plus its overlay (display_terrain.h).
class HeightSource {
 public:
  virtual ~HeightSource() = default;
  virtual const WorldParams& params() const = 0;
  // Mip-`mip` samples of `rect` (that mip's grid: sample i is mip-0 sample i * 2^mip),
  // row-major into `out` (rect.area() values). Samples outside the world repeat the mip's
  // edge sample (LevelAxis).
  virtual void read(int32_t mip, const RectI& rect, std::span<uint16_t> out) const = 0;
  // Detail offsets of a rect of the detail grid (0 where there are none).
  virtual void read_detail(const RectI& rect, std::span<int8_t> out) const;
  // How mip-`mip` samples of `rect` differ from the session's initial terrain, in meters
  // (negative: dug; positive: raised), row-major into `out`: the renderer's dug-material layer.
  // False (nothing written) when the source does not know the initial terrain.
  virtual bool read_change(int32_t mip, const RectI& rect, std::span<float> out) const;
};

// The lowest and highest height of the source's coarsest mip, in meters above the height
// offset: the renderers' material range. Every source holds that mip (a viewer subscribes it
// first), so the same terrain gets the same colours from a DEM, a snapshot or a session.
std::array<double, 2> coarsest_height_range_m(const HeightSource& source);

// The ground's height (m) at world point (x, y) (m): bilinear between mip-0 samples, as the
// finest level draws it (past the world's edge, its edge samples).
double ground_height(const HeightSource& source, double x, double y);

class WorldHeightSource final : public HeightSource {
 public:
  // `initial`, when given, is the terrain before the session's edits (same params): changes
  // are measured against it.
  explicit WorldHeightSource(const World& world, const World* initial = nullptr)
      : world_(world), initial_(initial) {}
  const WorldParams& params() const override { return world_.params(); }
  void read(int32_t mip, const RectI& rect, std::span<uint16_t> out) const override;
  void read_detail(const RectI& rect, std::span<int8_t> out) const override;
  bool read_change(int32_t mip, const RectI& rect, std::span<float> out) const override;

 private:
  const World& world_;
  const World* initial_ = nullptr;
};

}  // namespace loam::terrain
