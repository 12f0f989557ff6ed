// Stamp validation and quantization: StampParams (untrusted, world units) -> QuantizedStamp.
//
// validate_stamp is the only way a stamp enters the system: it rejects non-finite values,
// radii <= 0 or above the configured maximum, unknown kinds, layers and blend modes, centers
// outside the world, unregistered texture ids and kind-specific fields out of range, each
// with an Error naming the field and the reason. What it accepts it quantizes to integers
// (docs/stamps.md, "Quantization"); the QuantizedStamp is the stamp from then on.
// check_quantized re-checks a QuantizedStamp that arrived from the wire or the log (also
// untrusted) against the same limits. Pure functions: safe on any input; they change nothing.
#pragma once

#include <cstdint>

#include "protocol/geometry.h"
#include "protocol/layer.h"
#include "protocol/result.h"
#include "protocol/stamps/stamp.h"
#include "protocol/stamps/texture_registry.h"

namespace loam {

// Hard ceiling of any configured radius, in layer samples: keeps every stamp-relative Q8
// offset below 2^31 (docs/stamps.md, "Bit budget").
inline constexpr double kHardMaxRadiusSamples = 65536.0;

// Shockwave Courant cap: nu^2 <= 0.49 in Q16 (an integer leapfrog blows up at nu^2 = 1/2).
inline constexpr int32_t kWaveNu2CapQ16 = 32112;

struct StampLimits {
  double max_radius_samples = 4096.0;              // in the stamp's layer samples, <= kHardMaxRadiusSamples
  uint32_t max_shockwave_steps = 1024;             // requested steps (before any split)
  int64_t max_shockwave_cells = int64_t(1) << 24;  // area of the final shockwave box
  friend bool operator==(const StampLimits&, const StampLimits&) = default;
};
// Hard ceilings of the limits themselves.
inline constexpr uint32_t kHardMaxShockwaveSteps = 65535;
inline constexpr int64_t kHardMaxShockwaveCells = int64_t(1) << 32;

// Checks that limits are usable: finite, positive, within the hard ceilings (a NaN radius
// would otherwise turn every radius comparison off). The error names the limit.
Status validate_limits(const StampLimits& limits);

// Validates and quantizes. `textures` may be null (then no texture id is registered).
Result<QuantizedStamp> validate_stamp(const StampParams& params, const WorldParams& world,
                                      const StampLimits& limits = {},
                                      const TextureRegistry* textures = nullptr);

// Re-checks an already quantized stamp (from the wire or the log).
Status check_quantized(const QuantizedStamp& q, const WorldParams& world, const StampLimits& limits = {},
                       const TextureRegistry* textures = nullptr);

// Number of sub-steps each requested shockwave step is split into so that the sub-step
// Courant number squared stays at or below kWaveNu2CapQ16 (1 when speed is below the cap).
int32_t shockwave_substeps(uint16_t speed_q16);
// nu^2 of one sub-step in Q16: round(speed^2 / substeps^2).
int32_t shockwave_nu2_q16(uint16_t speed_q16, int32_t substeps);

}  // namespace loam
