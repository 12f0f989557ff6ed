// Stamp records: what a user asks for (StampParams, world units) and the quantized form
// (QuantizedStamp, integers) that validation produces. The quantized form is the stamp from
// then on: it travels on the wire and in the log, and every backend (CPU reference, GPU,
// client prediction, replay) evaluates exactly it. docs/stamps.md gives every field's units.
#pragma once

#include <cstdint>

#include "protocol/geometry.h"

namespace loam {

enum class StampKind : uint8_t {
  kTexture = 0,    // grayscale image, rotated and scaled
  kGaussian = 1,   // smooth bump or dent
  kCrater = 2,     // bowl and raised rim, optionally volume-conserving
  kFootprint = 3,  // pressed from the first point of contact
  kFlatten = 4,    // toward a target height with a soft edge
  kShockwave = 5,  // N steps of a damped 2D wave equation, applied atomically
};
inline constexpr int kStampKindCount = 6;
const char* to_string(StampKind kind);

enum class BlendMode : uint8_t { kAdd = 0, kSubtract = 1, kMin = 2, kMax = 3 };
inline constexpr int kBlendModeCount = 4;
const char* to_string(BlendMode mode);

inline constexpr uint8_t kStampFlagVolumeConserving = 1u << 0;  // crater only
inline constexpr uint8_t kStampKnownFlags = kStampFlagVolumeConserving;

// Fixed-point scales of QuantizedStamp.
inline constexpr int32_t kPositionFracBits = 8;   // positions and radii: 1/256 sample
inline constexpr int32_t kIntensityFracBits = 8;  // heights: 1/256 layer height unit
inline constexpr uint32_t kRotationUnitsPerTurn = 65536;
inline constexpr uint32_t kUnitFracOne = 65536;  // Q16 fractions (damping, shape, speed)

// A stamp as a user or bot asks for it, in world units. Not trusted: validate first.
struct StampParams {
  StampKind kind = StampKind::kGaussian;
  Layer layer = Layer::kCoarse;
  BlendMode blend = BlendMode::kAdd;
  double center_x = 0.0;  // world meters
  double center_y = 0.0;  // world meters
  double radius = 1.0;    // meters (texture: half the side of the scaled image)
  double rotation = 0.0;  // radians, counter-clockwise
  double intensity =
      0.0;  // meters, signed (crater: depth; footprint: depth; flatten: strength 0..1 as meters of pull)
  double target = 0.0;             // flatten: target height in meters
  double shape = 0.0;              // kind-specific 0..1 (crater: rim height relative to depth)
  double damping = 0.0;            // shockwave: fraction of velocity removed per step, 0..1
  double speed = 0.5;              // shockwave: Courant number nu = c dt / h (capped below 1/sqrt 2)
  uint32_t steps = 0;              // shockwave: number of steps
  uint32_t seed = 0;               // kinds with noise
  uint64_t texture_id = 0;         // texture: content hash of a registered image
  bool volume_conserving = false;  // crater
};

// The quantized stamp. All positions are in the stamp's layer's global sample grid.
struct QuantizedStamp {
  StampKind kind = StampKind::kGaussian;
  Layer layer = Layer::kCoarse;
  BlendMode blend = BlendMode::kAdd;
  uint8_t flags = 0;      // kStampFlag*
  int64_t center_x = 0;   // layer samples, Q.8
  int64_t center_y = 0;   // layer samples, Q.8
  uint32_t radius = 0;    // layer samples, Q.8, > 0
  uint16_t rotation = 0;  // 1/65536 turn
  int32_t intensity = 0;  // layer height units, Q.8, signed
  int32_t target = 0;     // flatten: target in layer height units (coarse 0..65535)
  uint16_t shape = 0;     // Q16 fraction
  uint16_t damping = 0;   // Q16 fraction
  uint16_t speed = 0;     // Q16 Courant number
  uint16_t steps = 0;     // shockwave steps
  uint32_t seed = 0;
  uint64_t texture_id = 0;

  friend bool operator==(const QuantizedStamp&, const QuantizedStamp&) = default;
};

// A footprint's first point of contact, measured on the mip-0 terrain under the foot. It is
// the one input of a per-sample stamp that is not the stamp itself, so a DeformEvent carries
// it and a client holding only some tiles (or only coarse mips) applies the footprint exactly.
struct FootprintContact {
  bool touches = false;   // some sample lies under the foot (else the footprint changes nothing)
  int32_t height_q8 = 0;  // layer units, Q8; 0 when !touches
  friend bool operator==(const FootprintContact&, const FootprintContact&) = default;
};

}  // namespace loam
