#include "protocol/stamps/stamp_validate.h"

#include <cmath>
#include <string>

#include "protocol/stamps/stamp_kinds.h"

namespace loam {

namespace {

Error bad(const char* field, std::string why, ErrorCode code = ErrorCode::kInvalidArgument) {
  return make_error(code, std::string("stamp.") + field, std::move(why));
}

Status require_finite(const char* field, double v) {
  if (!std::isfinite(v)) return bad(field, "must be a finite number", ErrorCode::kNotFinite);
  return {};
}

// Round to nearest (ties away from zero) for |v| < 2^62; llround is exact, not a libm
// approximation, so it is the same everywhere.
int64_t round_i64(double v) { return int64_t(std::llround(v)); }

// Whether the target height means anything (docs/stamps.md: else it must be 0).
bool uses_target(StampKind k, BlendMode b) {
  return stamp_kind(k).uses_target || b == BlendMode::kMin || b == BlendMode::kMax;
}

// Crater rim, footprint and flatten edge softness (docs/stamps.md: else 0).
bool has_shape(StampKind k) { return stamp_kind(k).uses_shape; }

bool own_combination(StampKind k) { return stamp_kind(k).own_combination; }

// Half side of the final shockwave box in layer samples (radius + every sub-step + margin).
int64_t shockwave_half_side(uint32_t radius_q8, uint16_t steps, uint16_t speed) {
  return int64_t(radius_q8 >> kPositionFracBits) + 2 + int64_t(steps) * shockwave_substeps(speed);
}

}  // namespace

int32_t shockwave_substeps(uint16_t speed_q16) {
  const int64_t nu2 = (int64_t(speed_q16) * speed_q16 + (1 << 15)) >> 16;
  int32_t k = 1;
  while (nu2 > int64_t(kWaveNu2CapQ16) * k * k) ++k;
  return k;
}

int32_t shockwave_nu2_q16(uint16_t speed_q16, int32_t substeps) {
  const int64_t den = int64_t(substeps) * substeps << 16;
  return int32_t((int64_t(speed_q16) * speed_q16 + den / 2) / den);
}

Result<QuantizedStamp> validate_stamp(const StampParams& p, const WorldParams& world,
                                      const StampLimits& limits, const TextureRegistry* textures) {
  if (uint8_t(p.kind) >= kStampKindCount) {
    return bad("kind", "unknown stamp kind " + std::to_string(int(p.kind)), ErrorCode::kBadEnum);
  }
  if (uint8_t(p.layer) > uint8_t(Layer::kDetail)) {
    return bad("layer", "unknown layer " + std::to_string(int(p.layer)), ErrorCode::kBadEnum);
  }
  if (uint8_t(p.blend) >= kBlendModeCount) {
    return bad("blend", "unknown blend mode " + std::to_string(int(p.blend)), ErrorCode::kBadEnum);
  }
  LOAM_TRY(require_finite("center_x", p.center_x));
  LOAM_TRY(require_finite("center_y", p.center_y));
  LOAM_TRY(require_finite("radius", p.radius));
  LOAM_TRY(require_finite("rotation", p.rotation));
  LOAM_TRY(require_finite("intensity", p.intensity));
  LOAM_TRY(require_finite("target", p.target));
  LOAM_TRY(require_finite("shape", p.shape));
  LOAM_TRY(require_finite("damping", p.damping));
  LOAM_TRY(require_finite("speed", p.speed));

  const double mps = layer_meters_per_sample(world, p.layer);
  const double mpu = layer_meters_per_unit(world, p.layer);
  QuantizedStamp q;
  q.kind = p.kind;
  q.layer = p.layer;
  q.blend = p.blend;
  q.seed = p.seed;

  // Center: Q8 layer samples, inside the world's extent [x0, x1) (in samples).
  const RectI r = layer_sample_rect(world, p.layer);
  const double cx = p.center_x / mps * 256.0, cy = p.center_y / mps * 256.0;
  if (!(cx >= double(r.x0) * 256.0 && cx < double(r.x1) * 256.0)) {
    return bad("center_x", "outside the world (" + std::to_string(double(r.x0) * mps) + " .. " +
                               std::to_string(double(r.x1) * mps) + " m)");
  }
  if (!(cy >= double(r.y0) * 256.0 && cy < double(r.y1) * 256.0)) {
    return bad("center_y", "outside the world (" + std::to_string(double(r.y0) * mps) + " .. " +
                               std::to_string(double(r.y1) * mps) + " m)");
  }
  q.center_x = std::min(round_i64(cx), r.x1 * 256 - 1);
  q.center_y = std::min(round_i64(cy), r.y1 * 256 - 1);

  // Radius: Q8 layer samples, at least 1/256 sample.
  if (!(p.radius > 0.0)) return bad("radius", "must be > 0");
  const double max_r = std::min(limits.max_radius_samples, kHardMaxRadiusSamples);
  const double radius_samples = p.radius / mps;
  if (radius_samples > max_r) {
    return bad("radius", "above the maximum of " + std::to_string(max_r * mps) + " m", ErrorCode::kOversize);
  }
  q.radius = uint32_t(std::max<int64_t>(1, round_i64(radius_samples * 256.0)));

  // Rotation: 1/65536 turn, reduced modulo one turn.
  if (std::fabs(p.rotation) > 1.0e6) return bad("rotation", "magnitude above 1e6 radians");
  constexpr double kTwoPi = 6.283185307179586;
  q.rotation = uint16_t(floor_mod(round_i64(p.rotation / kTwoPi * 65536.0), 65536));

  // Intensity.
  const int32_t max_units = layer_max(p.layer) - layer_min(p.layer);  // the layer's span
  if (p.kind == StampKind::kFlatten) {
    if (p.intensity < 0.0 || p.intensity > 1.0) return bad("intensity", "flatten strength must be in [0, 1]");
    q.intensity = int32_t(round_i64(p.intensity * 65536.0));
  } else {
    const double units = p.intensity / mpu;
    if (std::fabs(units) > double(max_units)) {
      return bad("intensity", "magnitude above " + std::to_string(double(max_units) * mpu) + " m for the " +
                                  to_string(p.layer) + " layer");
    }
    q.intensity = int32_t(round_i64(units * 256.0));
    if (p.kind == StampKind::kFootprint && q.intensity < 0) {
      return bad("intensity", "footprint depth must be >= 0");
    }
  }

  // Target height: used by flatten and by the min / max blends, and 0 everywhere else.
  if (!uses_target(p.kind, p.blend)) {
    if (p.target != 0.0) {
      return bad("target", std::string("must be 0: a ") + to_string(p.kind) + " with the " +
                               to_string(p.blend) +
                               " blend has no target (only flatten and the min/max blends take one)");
    }
  } else {
    const double units = (p.target - layer_zero_meters(world, p.layer)) / mpu;
    if (!(units >= double(layer_min(p.layer)) - 0.5 && units < double(layer_max(p.layer)) + 0.5)) {
      return bad("target", "outside the " + std::string(to_string(p.layer)) + " layer's height range");
    }
    q.target = int32_t(round_i64(units));
  }

  // Kind-specific fractions.
  if (has_shape(p.kind)) {
    if (p.shape < 0.0 || p.shape > 1.0) return bad("shape", "must be in [0, 1]");
    q.shape = uint16_t(std::min<int64_t>(65535, round_i64(p.shape * 65536.0)));
  }
  if (stamp_kind(p.kind).uses_wave) {
    if (p.damping < 0.0 || p.damping > 1.0) return bad("damping", "must be in [0, 1]");
    q.damping = uint16_t(std::min<int64_t>(65535, round_i64(p.damping * 65536.0)));
    if (!(p.speed > 0.0 && p.speed < 1.0)) {
      return bad("speed", "the Courant number must be in (0, 1); above 1/sqrt(2) steps are split");
    }
    q.speed = uint16_t(std::clamp<int64_t>(round_i64(p.speed * 65536.0), 1, 65535));
    if (p.steps == 0 || p.steps > limits.max_shockwave_steps || p.steps > 65535) {
      return bad("steps",
                 "must be in 1.." + std::to_string(std::min<uint32_t>(limits.max_shockwave_steps, 65535)));
    }
    q.steps = uint16_t(p.steps);
  }
  if (stamp_kind(p.kind).uses_texture) {
    if (textures == nullptr || !textures->contains(p.texture_id)) {
      return bad("texture_id", "no registered texture has this id", ErrorCode::kNotFound);
    }
    q.texture_id = p.texture_id;
  }
  if (p.volume_conserving) {
    if (p.kind != StampKind::kCrater) return bad("volume_conserving", "only craters can conserve volume");
    if (p.blend != BlendMode::kAdd && p.blend != BlendMode::kSubtract) {
      return bad("volume_conserving", "needs the add or subtract blend");
    }
    q.flags |= kStampFlagVolumeConserving;
  }
  if (own_combination(p.kind) && p.blend != BlendMode::kAdd) {
    return bad("blend", std::string(to_string(p.kind)) + " has its own combination; blend must be add");
  }
  LOAM_TRY(check_quantized(q, world, limits, textures));
  return q;
}

Status check_quantized(const QuantizedStamp& q, const WorldParams& world, const StampLimits& limits,
                       const TextureRegistry* textures) {
  if (uint8_t(q.kind) >= kStampKindCount) return bad("kind", "unknown stamp kind", ErrorCode::kBadEnum);
  if (uint8_t(q.layer) > uint8_t(Layer::kDetail)) return bad("layer", "unknown layer", ErrorCode::kBadEnum);
  if (uint8_t(q.blend) >= kBlendModeCount) return bad("blend", "unknown blend mode", ErrorCode::kBadEnum);
  if ((q.flags & ~kStampKnownFlags) != 0) return bad("flags", "unknown flag bits", ErrorCode::kBadEnum);
  const RectI r = layer_sample_rect(world, q.layer);
  if (q.center_x < r.x0 * 256 || q.center_x >= r.x1 * 256) return bad("center_x", "outside the world");
  if (q.center_y < r.y0 * 256 || q.center_y >= r.y1 * 256) return bad("center_y", "outside the world");
  const double max_r = std::min(limits.max_radius_samples, kHardMaxRadiusSamples);
  if (q.radius == 0) return bad("radius", "must be > 0");
  if (double(q.radius) > max_r * 256.0)
    return bad("radius", "above the configured maximum", ErrorCode::kOversize);
  const int32_t max_units = layer_max(q.layer) - layer_min(q.layer);
  if (q.kind == StampKind::kFlatten) {
    if (q.intensity < 0 || q.intensity > 65536)
      return bad("intensity", "flatten strength must be in [0, 65536]");
  } else if (q.intensity < -max_units * 256 || q.intensity > max_units * 256) {
    return bad("intensity", "out of the layer's range");
  }
  if (q.kind == StampKind::kFootprint && q.intensity < 0)
    return bad("intensity", "footprint depth must be >= 0");
  if (q.target < layer_min(q.layer) || q.target > layer_max(q.layer)) {
    return bad("target", "outside the layer's height range");
  }
  if (!uses_target(q.kind, q.blend) && q.target != 0) {
    return bad("target", "must be 0 where neither flatten nor a min/max blend uses it");
  }
  // The kind-specific fields are 0 on the other kinds (validate_stamp never sets them there).
  if (!has_shape(q.kind) && q.shape != 0)
    return bad("shape", "must be 0: only crater, footprint and flatten have one");
  if (!stamp_kind(q.kind).uses_wave) {
    if (q.damping != 0) return bad("damping", "must be 0: only a shockwave has one");
    if (q.speed != 0) return bad("speed", "must be 0: only a shockwave has one");
    if (q.steps != 0) return bad("steps", "must be 0: only a shockwave has them");
  }
  if (!stamp_kind(q.kind).uses_texture && q.texture_id != 0)
    return bad("texture_id", "must be 0: only a texture stamp has one");
  if ((q.flags & kStampFlagVolumeConserving) != 0 &&
      (q.kind != StampKind::kCrater || (q.blend != BlendMode::kAdd && q.blend != BlendMode::kSubtract))) {
    return bad("flags", "volume conservation needs a crater with the add or subtract blend");
  }
  if (own_combination(q.kind) && q.blend != BlendMode::kAdd) return bad("blend", "must be add for this kind");
  if (stamp_kind(q.kind).uses_texture && (textures == nullptr || !textures->contains(q.texture_id))) {
    return bad("texture_id", "no registered texture has this id", ErrorCode::kNotFound);
  }
  if (q.kind == StampKind::kShockwave) {
    if (q.speed == 0) return bad("speed", "must be > 0");
    if (q.steps == 0 || q.steps > limits.max_shockwave_steps) return bad("steps", "out of range");
    const int64_t half = shockwave_half_side(q.radius, q.steps, q.speed);
    if ((2 * half + 1) * (2 * half + 1) > limits.max_shockwave_cells) {
      return bad("steps",
                 "the shockwave box would exceed " + std::to_string(limits.max_shockwave_cells) + " cells",
                 ErrorCode::kOversize);
    }
  }
  return {};
}

Status validate_limits(const StampLimits& limits) {
  if (!std::isfinite(limits.max_radius_samples) || !(limits.max_radius_samples > 0.0) ||
      limits.max_radius_samples > kHardMaxRadiusSamples) {
    return make_error(ErrorCode::kInvalidArgument, "limits.max_radius_samples",
                      "must be a finite number in (0, " + std::to_string(int64_t(kHardMaxRadiusSamples)) +
                          "], got " + std::to_string(limits.max_radius_samples));
  }
  if (limits.max_shockwave_steps < 1 || limits.max_shockwave_steps > kHardMaxShockwaveSteps) {
    return make_error(ErrorCode::kInvalidArgument, "limits.max_shockwave_steps",
                      "must be in 1.." + std::to_string(kHardMaxShockwaveSteps) + ", got " +
                          std::to_string(limits.max_shockwave_steps));
  }
  if (limits.max_shockwave_cells < 1 || limits.max_shockwave_cells > kHardMaxShockwaveCells) {
    return make_error(ErrorCode::kInvalidArgument, "limits.max_shockwave_cells",
                      "must be in 1.." + std::to_string(kHardMaxShockwaveCells) + ", got " +
                          std::to_string(limits.max_shockwave_cells));
  }
  return {};
}

}  // namespace loam
