// Refinement: a small coarse height grid (the "source") turned into a world 2^levels times
// finer per axis, tile by tile, so untouched terrain is computed where it is needed and
// never stored or sent. Server and clients evaluate it identically: integer arithmetic only,
// no floating point, no library calls whose results could differ between compilers.
//
// The method (docs/world.md, "Refined worlds"): level `levels` is the source itself; each
// finer level L keeps every sample of level L+1 and inserts the midpoints between them with
// the 4-point interpolatory subdivision of Dubuc and Deslauriers, (-a + 9b + 9c - d) / 16,
// first along x, then along y, then adds to every inserted sample a displacement drawn from
// a hash of (seed, level, position) and scaled by the level's amplitude and by the source's
// local relief. Level 0 is mip 0. Because a level keeps the samples of the level above, the
// sample at mip m is the level-m value itself: a mip-m tile costs only the levels down to m,
// and mips agree with mip 0 by construction (mip m holds every 2^m-th mip-0 sample). Every
// value is a function of its global position alone, so tiles, seams and four-tile corners
// are continuous: a tile equals the same rect of any larger evaluation.
//
// Safe on any source and parameters that pass validation: intermediate values are clamped
// to a range that cannot overflow, and output saturates to 0..65535.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "protocol/geometry.h"
#include "protocol/result.h"

namespace loam {

inline constexpr int32_t kMaxRefineLevels = 12;

struct RefinementParams {
  int32_t levels = 7;  // the world is 2^levels times finer than the source per axis (1..12)
  uint64_t seed = 0;
  // Displacement amplitude of the samples inserted at level L (index L, 0 = mip 0), in
  // 1/16 height units for a roughness of 1.0. A hash gives a triangular variate in
  // [-1, 1); the displacement is variate * amplitude * roughness.
  std::array<int32_t, kMaxRefineLevels> amplitude{};
  // Roughness of a source sample, in 1/256: base + gain * relief / 256, clamped to
  // [0, max], where relief is max - min of the source over its 3x3 neighbourhood (height
  // units). Inserted samples take the mean of their neighbours' roughness.
  int32_t roughness_base = 256;
  int32_t roughness_gain = 0;
  int32_t roughness_max = 1024;

  // Checks every field against its documented range; the error names the field.
  Status validate() const;
  friend bool operator==(const RefinementParams&, const RefinementParams&) = default;
};

class RefinedBase {
 public:
  RefinedBase() = default;  // empty (0 x 0); create() makes a usable one
  // `source` is row-major width x height, in height units of the refined world (values
  // outside 0..65535 are allowed and saturate on output). Sizes 1..65536 per axis.
  static Result<RefinedBase> create(int32_t width, int32_t height, std::span<const int32_t> source,
                                    const RefinementParams& params);

  const RefinementParams& params() const { return params_; }
  int32_t source_width() const { return width_; }
  int32_t source_height() const { return height_; }
  // A hash of the method's version, the parameters and the source: equal identities give
  // equal worlds.
  uint64_t identity() const { return identity_; }
  // Size of the refined world in mip-0 samples: source size << levels.
  int64_t width() const { return int64_t(width_) << params_.levels; }
  int64_t height() const { return int64_t(height_) << params_.levels; }

  // Samples of mip `mip` (0..kMaxMips-1) over `rect` in that mip's global sample grid
  // (sample i is mip-0 sample i * 2^mip), row-major into `out` of rect.area() samples.
  // Positions outside the world continue the refinement of the edge-clamped source; the
  // world's own samples never depend on them beyond the subdivision's reach.
  // Thread-safe: uses per-thread scratch memory.
  void generate(int32_t mip, const RectI& rect, std::span<uint16_t> out) const;
  // One kTileSize^2 tile of mip `mip` (tile coordinates in that mip's grid).
  void generate_tile(int32_t mip, int32_t tx, int32_t ty, std::span<uint16_t> out) const {
    generate(mip, tile_rect(tx, ty), out);
  }

 private:
  RefinementParams params_;
  int32_t width_ = 0, height_ = 0;
  std::vector<int32_t> source16_;   // source in 1/16 height units, clamped
  std::vector<int32_t> roughness_;  // per source sample, 1/256
  std::array<uint64_t, kMaxRefineLevels> level_seed_{};
  uint64_t identity_ = 0;
};

}  // namespace loam
