// Which tiles a clipmap viewer subscribes to (the classic clipmap's levels placed here, or any
// scheme's level regions given): level l reads mip l (or the coarsest mip the
// world has, for levels beyond it), so it needs the mip tiles under its texture region; the
// finest levels also want mip 0 near the camera (edits are predicted only on held mip-0 tiles)
// and the detail tiles there; the coarsest mip's tiles are always held, so something shows
// everywhere while the finer tiles load. Pure logic (no GL, no sockets): the camera goes in,
// the Subscribe / Unsubscribe lists come out, with hysteresis so a camera moving back and
// forth over a tile border does not thrash.
#pragma once

#include <cstdint>
#include <set>
#include <span>
#include <vector>

#include "protocol/geometry.h"

namespace loam::lod {

struct InterestConfig {
  int32_t n = 127;              // clipmap vertices per level side
  int32_t levels = 7;           // clipmap levels
  int32_t pad = 5;              // texture border beyond the level's vertices (ClipmapRenderer::kLevelPad)
  int32_t margin = 32;          // level samples beyond the region that are subscribed ahead
  double mip0_radius_m = 384;   // mip-0 coarse tiles within this distance of the camera
  double detail_radius_m = 96;  // detail tiles within this distance (0: none)
};

// Every tile needed for a camera at (cam_x, cam_y) world meters, grown by `margin` (level
// samples, and meters scaled alike for the mip-0 and detail radii), clipped to the world.
std::set<TileCoord> clipmap_tiles(const WorldParams& world, const InterestConfig& config, double cam_x,
                                  double cam_y, int32_t margin);
// The same where the levels' regions are given (the error-driven clipmap places its own):
// regions[l] holds level l's samples (the world's grid at spacing 2^l, half-open), each grown
// by `margin`; n, levels and pad are not used.
std::set<TileCoord> region_tiles(const WorldParams& world, const InterestConfig& config,
                                 std::span<const RectI> regions, double cam_x, double cam_y, int32_t margin);

class ClipmapInterest {
 public:
  ClipmapInterest(const WorldParams& world, const InterestConfig& config) : world_(world), config_(config) {}

  struct Delta {
    std::vector<TileCoord> subscribe, unsubscribe;
    bool empty() const { return subscribe.empty() && unsubscribe.empty(); }
  };
  // New tiles needed within the margin are subscribed; held ones no longer needed within
  // twice the margin are dropped. With `regions`, the levels hold those (region_tiles).
  Delta update(double cam_x, double cam_y, std::span<const RectI> regions = {});
  const std::set<TileCoord>& subscribed() const { return subscribed_; }

 private:
  WorldParams world_;
  InterestConfig config_;
  std::set<TileCoord> subscribed_;
};

}  // namespace loam::lod
