// The seeded stamp mix: random stamps for `loam-client bot`, the tests, the benchmarks and the
// golden stamp sequence. One generator, so the bot and every suite draw the same mix of kinds,
// layers, blends and parameters, and options
// (kind set, layer share, center bounds, radius range, intensities, targets) adapt it to a
// world instead of each suite writing its own. random_edge_case_stamp_params draws the hard
// cases a kernel compared sample by sample needs from the same generator.
//
// The generator is the golden stamp sequence's (tests/determinism/stamp_sequence.cpp): an
// integer LCG and a fixed order of draws, so with the default options it reproduces that
// sequence bit for bit on any compiler and standard library (<random>'s distributions are
// not portable). Changing the order or arithmetic of the draws changes the golden hash
// kGoldenStampSequenceHash. Part of the protocol library, so the bot needs no test code.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <span>
#include <vector>

#include "protocol/result.h"
#include "protocol/stamps/stamp.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/stamps/texture_registry.h"
#include "protocol/world.h"

namespace loam {

// Knuth's MMIX linear congruential generator. Every draw is one step, and its value the top
// 31 bits of the state (the low bits of an LCG are weak).
class StampRng {
 public:
  explicit StampRng(uint64_t seed) : state_(seed) {}
  uint32_t next() {
    state_ = state_ * 6364136223846793005ull + 1442695040888963407ull;
    return uint32_t(state_ >> 33);
  }
  uint32_t below(uint32_t n) { return next() % n; }  // [0, n), n > 0
  // [lo, hi]; hi - lo < 2^31.
  int64_t range(int64_t lo, int64_t hi) { return lo + int64_t(below(uint32_t(hi - lo + 1))); }
  double unit() { return double(next()) / 2147483648.0; }  // [0, 1)
  bool chance(uint32_t percent) { return below(100) < percent; }

 private:
  uint64_t state_;
};

// Every kind, in StampKind order.
std::vector<StampKind> all_stamp_kinds();
// No radius cap for any kind.
std::array<double, kStampKindCount> unlimited_radii();

struct RandomStampOptions {
  std::vector<StampKind> kinds = all_stamp_kinds();  // drawn uniformly; not empty
  // Blends of gaussian and texture stamps, drawn uniformly; not empty. The others add.
  std::vector<BlendMode> blends = {BlendMode::kAdd, BlendMode::kSubtract, BlendMode::kMin, BlendMode::kMax};
  // Each layer's share of the stamps: a stamp goes on layer L with probability share[L] / the
  // sum (a layer with no share: none). Default: 1 in 3 on the detail layer.
  PerLayer<uint32_t> layer_share{{2, 1}};
  // Centers: world meters in [x0, x1) x [y0, y1) on a grid of 1 / center_steps_per_meter m.
  double x0 = -250.0, y0 = -250.0, x1 = 250.0, y1 = 250.0;
  uint32_t center_steps_per_meter = 8;
  // Radii: meters in [min_radius, max_radius) on a grid of 1 / radius_steps_per_meter m.
  double min_radius = 0.5, max_radius = 40.5;
  uint32_t radius_steps_per_meter = 10;
  // Largest |intensity| in meters, per layer. Keep 100 / value exact (5, 0.5, 2, 0.25...): the
  // draw divides by it, and the golden sequence depends on that arithmetic.
  PerLayer<double> max_intensity{{5.0, 0.5}};
  // Smallest |intensity| in meters, per layer, and smallest flatten strength: a smaller draw
  // is raised to it (sign kept). For callers that wait for every stamp's event, which a stamp
  // that changes nothing never sends. 0: as drawn.
  PerLayer<double> min_intensity{};
  double min_flatten_strength = 0.0;
  // Flatten, min and max targets per layer: whole meters drawn in [min, max), or fixed at min.
  struct TargetRange {
    double min = 0.0, max = 0.0;
    bool drawn = false;
  };
  PerLayer<TargetRange> targets{{TargetRange{100.0, 1000.0, true}, TargetRange{0.1, 0.1, false}}};
  uint64_t texture_id = 0;  // texture stamps need a registered image
  // Applied after the draws, which stay the same: a stamp drawn for a layer that does not take
  // its kind goes on the coarse layer, and a kind's radius is capped (a shockwave's cost grows
  // with its area; a footprint's contact reads every tile it overlaps).
  PerLayer<std::vector<StampKind>> layer_kinds{{all_stamp_kinds(), all_stamp_kinds()}};
  std::array<double, kStampKindCount> max_radius_of_kind = unlimited_radii();
};

// Options for `world`: centers anywhere on its coarse samples, coarse targets inside its
// height range, no texture stamps (no image is registered).
RandomStampOptions random_stamp_options(const WorldParams& world);

// One draw. It may not validate (e.g. a footprint on the detail layer near an edge).
StampParams random_stamp_params(StampRng& rng, const RandomStampOptions& options);

// Hard cases for a kernel compared sample by sample with the reference: centers on the
// layer's sample 0 (a tile corner) or on the world's edge half the time, always with a
// sub-sample offset; radii log-uniform from 1/256 sample to `max_radius_samples` samples of
// the stamp's layer; intensities at the layer's limit one time in five, so every blend
// saturates; all four blends (footprint and flatten: add). Uses options.kinds,
// layer_share and texture_id (a texture draw becomes a gaussian where it is 0).
StampParams random_edge_case_stamp_params(StampRng& rng, const WorldParams& world, double max_radius_samples,
                                          const RandomStampOptions& options);

// Draws until validate_stamp accepts one, at most `attempts` draws; the last error if none.
Result<QuantizedStamp> random_valid_stamp(StampRng& rng, const RandomStampOptions& options,
                                          const WorldParams& world, const StampLimits& limits = {},
                                          const TextureRegistry* textures = nullptr, int attempts = 100);

// A quantized stamp drawn field by field, for kernels compared texel for texel: any kind
// (the shockwave when allowed), either layer, centers anywhere, on a tile border, at the world's
// edge or on a four-tile corner with a sub-sample offset, radii from 1/256 sample to the
// maximum, saturating intensities a third of the time, any blend, rotation, shape, target,
// volume-conserving craters and shockwave speeds above the cap. Texture stamps take one of
// `texture_ids`. Fields a kind does not use are 0 (docs/stamps.md); the stamp may still fail
// check_quantized (a caller skips those).
QuantizedStamp random_quantized_stamp(StampRng& rng, const WorldParams& world,
                                      std::span<const uint64_t> texture_ids, bool allow_shockwave);

}  // namespace loam
