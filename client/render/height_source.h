// What the clipmap levels read: a HeightSource answers mip samples of any rect (clamped at
// the world's edge), detail offsets, and how the terrain changed against the session's initial
// state. No GL: the renderer, the display terrain and tests share it.
#pragma once

#include <cstdint>
#include <span>

#include "protocol/geometry.h"
#include "protocol/world.h"

namespace loam::render {

// Where level textures get their samples: the server's world, a local DEM, or the
// client's confirmed store plus its overlay (display_terrain.h).
class HeightSource {
 public:
  virtual ~HeightSource() = default;
  virtual const WorldParams& params() const = 0;
  // Mip-`mip` samples of `rect` (that mip's grid: sample i is mip-0 sample i * 2^mip),
  // row-major into `out` (rect.area() values). Samples outside the world clamp to its edge.
  virtual void read(int32_t mip, const RectI& rect, std::span<uint16_t> out) const = 0;
  // Detail offsets of a rect of the detail grid (0 where there are none).
  virtual void read_detail(const RectI& rect, std::span<int8_t> out) const;
  // How mip-`mip` samples of `rect` differ from the session's initial terrain, in meters
  // (negative: dug; positive: raised), row-major into `out`: the renderer's dug-material layer.
  // False (nothing written) when the source does not know the initial terrain.
  virtual bool read_change(int32_t mip, const RectI& rect, std::span<float> out) const;
};

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

}  // namespace loam::render
