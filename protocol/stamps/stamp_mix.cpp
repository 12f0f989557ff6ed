#include "protocol/stamps/stamp_mix.h"

#include <algorithm>
#include <cmath>

namespace loam {

std::vector<StampKind> all_stamp_kinds() {
  std::vector<StampKind> kinds;
  for (int k = 0; k < kStampKindCount; ++k) kinds.push_back(StampKind(k));
  return kinds;
}

std::array<double, kStampKindCount> unlimited_radii() {
  std::array<double, kStampKindCount> r;
  r.fill(std::numeric_limits<double>::infinity());
  return r;
}

RandomStampOptions random_stamp_options(const WorldParams& w) {
  RandomStampOptions o;
  o.kinds.erase(std::remove(o.kinds.begin(), o.kinds.end(), StampKind::kTexture), o.kinds.end());
  const RectI r = w.sample_rect();
  o.x0 = double(r.x0) * w.meters_per_sample;
  o.y0 = double(r.y0) * w.meters_per_sample;
  o.x1 = double(r.x1 - 1) * w.meters_per_sample;
  o.y1 = double(r.y1 - 1) * w.meters_per_sample;
  RandomStampOptions::TargetRange& t = o.targets[Layer::kCoarse];
  t.min = std::ceil(w.height_offset);
  t.max = std::max(t.min + 1.0, std::floor(w.height_offset + 65535.0 * w.meters_per_unit));
  return o;
}

namespace {
uint32_t steps(double lo, double hi, uint32_t per_meter) {
  return std::max<uint32_t>(1, uint32_t((hi - lo) * double(per_meter)));
}

// The layer of the next stamp by the shares: one draw in [0, sum) unless a single layer has
// a share. The ranges run from the last layer to the first, the order the golden sequence
// drew in (its detail third first).
Layer draw_layer(StampRng& rng, const PerLayer<uint32_t>& share) {
  uint32_t sum = 0;
  int sharing = 0;
  Layer only = kLayers[0];
  for (const Layer l : kLayers) {
    if (share[l] == 0) continue;
    sum += share[l];
    ++sharing;
    only = l;
  }
  if (sharing <= 1) return only;
  uint32_t x = rng.below(sum);
  for (size_t i = kLayerCount; i-- > 0;) {
    if (x < share[kLayers[i]]) return kLayers[i];
    x -= share[kLayers[i]];
  }
  return kLayers[0];
}
}  // namespace

// The order of the draws below is the golden sequence's: each one is made whether or not the
// kind uses it, so a change to one kind's parameters does not shift every later stamp.
StampParams random_stamp_params(StampRng& rng, const RandomStampOptions& o) {
  StampParams s;
  s.kind = o.kinds[rng.below(uint32_t(o.kinds.size()))];
  s.layer = draw_layer(rng, o.layer_share);
  const std::vector<StampKind>& takes = o.layer_kinds[s.layer];
  if (std::find(takes.begin(), takes.end(), s.kind) == takes.end()) s.layer = Layer::kCoarse;
  s.center_x =
      o.x0 + double(rng.below(steps(o.x0, o.x1, o.center_steps_per_meter))) / o.center_steps_per_meter;
  s.center_y =
      o.y0 + double(rng.below(steps(o.y0, o.y1, o.center_steps_per_meter))) / o.center_steps_per_meter;
  s.radius = o.min_radius + double(rng.below(steps(o.min_radius, o.max_radius, o.radius_steps_per_meter))) /
                                o.radius_steps_per_meter;
  s.rotation = double(rng.below(1000)) / 100.0;
  s.intensity = (double(rng.below(200)) - 100.0) / (100.0 / o.max_intensity[s.layer]);
  const double min_intensity = o.min_intensity[s.layer];
  if (std::fabs(s.intensity) < min_intensity)
    s.intensity = s.intensity < 0.0 ? -min_intensity : min_intensity;
  s.shape = double(rng.below(100)) / 100.0;
  s.texture_id = o.texture_id;
  s.steps = 1 + rng.below(20);
  s.speed = 0.2 + double(rng.below(70)) / 100.0;
  s.damping = double(rng.below(10)) / 100.0;
  if (s.kind == StampKind::kFlatten)
    s.intensity = std::max(double(rng.below(100)) / 100.0, o.min_flatten_strength);
  if (s.kind == StampKind::kFootprint) s.intensity = std::fabs(s.intensity);
  if (s.kind == StampKind::kCrater) s.volume_conserving = rng.below(2) == 1;
  const RandomStampOptions::TargetRange& range = o.targets[s.layer];
  const double target =
      range.drawn ? double(rng.below(steps(range.min, range.max, 1))) + range.min : range.min;
  if (s.kind == StampKind::kGaussian || s.kind == StampKind::kTexture)
    s.blend = o.blends[rng.below(uint32_t(o.blends.size()))];
  // Only flatten and the min/max blends take a target (the draw stays, so the sequence does).
  if (s.kind == StampKind::kFlatten || s.blend == BlendMode::kMin || s.blend == BlendMode::kMax)
    s.target = target;
  s.radius = std::min(s.radius, o.max_radius_of_kind[size_t(s.kind)]);
  return s;
}

StampParams random_edge_case_stamp_params(StampRng& rng, const WorldParams& p, double max_radius_samples,
                                          const RandomStampOptions& o) {
  StampParams s;
  s.kind = o.kinds[rng.below(uint32_t(o.kinds.size()))];
  if (s.kind == StampKind::kTexture && o.texture_id == 0) s.kind = StampKind::kGaussian;
  s.layer = draw_layer(rng, o.layer_share);
  const double spacing = layer_meters_per_sample(p, s.layer);
  const double unit = layer_meters_per_unit(p, s.layer);
  const int64_t max_units = layer_max(s.layer) - layer_min(s.layer);
  const RectI lr = layer_sample_rect(p, s.layer);
  auto coord = [&](int64_t lo, int64_t hi) {
    // Sample 0 (where tiles meet), the world's edges, or anywhere; a Q8 sub-sample offset
    // moves the center off the grid.
    const uint32_t pick = rng.below(4);
    int64_t base = pick == 0 ? 0 : pick == 1 ? (rng.chance(50) ? lo : hi - 1) : rng.range(lo, hi - 1);
    if (pick == 1 && base == hi - 1 && base < lo) base = lo;
    return (double(base) + double(rng.range(0, 255)) / 256.0) * spacing;
  };
  s.center_x = coord(lr.x0, lr.x1);
  s.center_y = coord(lr.y0, lr.y1);
  const double log_lo = std::log(1.0 / 256.0), log_hi = std::log(max_radius_samples);
  s.radius = std::exp(log_lo + (log_hi - log_lo) * rng.unit()) * spacing;
  s.rotation = double(rng.range(0, 65535)) / 65536.0 * 6.283185307179586;
  if (rng.chance(15)) s.rotation = double(rng.range(0, 3)) * 1.5707963267948966;  // quarter turns
  const int64_t units = rng.chance(20) ? max_units : rng.range(0, max_units / 8);
  s.intensity = double(units) * unit * (rng.chance(50) ? 1.0 : -1.0);
  s.blend = BlendMode(rng.range(0, 3));
  s.target = double(rng.range(layer_min(s.layer), layer_max(s.layer))) * unit + layer_zero_meters(p, s.layer);
  s.shape = rng.unit();
  s.texture_id = o.texture_id;
  switch (s.kind) {
    case StampKind::kFootprint:
      s.intensity = std::abs(s.intensity);
      s.blend = BlendMode::kAdd;
      break;
    case StampKind::kFlatten:
      s.intensity = rng.chance(20) ? 1.0 : rng.unit();
      s.blend = BlendMode::kAdd;
      break;
    case StampKind::kCrater:
      if (rng.chance(25) && (s.blend == BlendMode::kAdd || s.blend == BlendMode::kSubtract)) {
        s.volume_conserving = true;
      }
      break;
    default: break;
  }
  // Only flatten and the min/max blends take a target.
  if (s.blend != BlendMode::kMin && s.blend != BlendMode::kMax && s.kind != StampKind::kFlatten)
    s.target = 0.0;
  return s;
}

Result<QuantizedStamp> random_valid_stamp(StampRng& rng, const RandomStampOptions& options,
                                          const WorldParams& world, const StampLimits& limits,
                                          const TextureRegistry* textures, int attempts) {
  Error last = make_error(ErrorCode::kInvalidArgument, "attempts", "no draws allowed");
  for (int i = 0; i < attempts; ++i) {
    auto q = validate_stamp(random_stamp_params(rng, options), world, limits, textures);
    if (q.ok()) return q;
    last = q.error();
  }
  return last;
}

// A Q8 coordinate somewhere interesting on an axis of `r` (layer samples).
namespace {

int64_t pick_coordinate(StampRng& rng, const RectI& r, bool x_axis, int64_t corner_pick) {
  const int64_t lo = x_axis ? r.x0 : r.y0, hi = x_axis ? r.x1 : r.y1;
  const int64_t frac = int64_t(rng.next() % 256);
  int64_t s;
  switch (corner_pick) {
    case 0: s = lo + int64_t(rng.next() % uint64_t(hi - lo)); break;  // anywhere
    case 1: {                                                         // a tile border
      const int64_t t =
          floor_div(lo, kTileSize) + 1 + int64_t(rng.next() % uint64_t((hi - lo) / kTileSize - 1));
      s = t * kTileSize + int64_t(rng.next() % 5) - 2;
      break;
    }
    case 2:
      s = rng.next() % 2 ? lo + int64_t(rng.next() % 3) : hi - 1 - int64_t(rng.next() % 3);
      break;                // world edge
    default: s = 0; break;  // the origin: a four-tile corner
  }
  s = std::clamp(s, lo, hi - 1);
  return s * 256 + frac;
}

}  // namespace

QuantizedStamp random_quantized_stamp(StampRng& rng, const WorldParams& world,
                                      std::span<const uint64_t> texture_ids, bool allow_shockwave) {
  QuantizedStamp q;
  const int kinds = allow_shockwave ? 6 : 5;
  q.kind = StampKind(rng.next() % uint64_t(kinds));
  q.layer = kLayers[rng.next() % kLayerCount];
  const RectI r = layer_sample_rect(world, q.layer);
  const int64_t pick = int64_t(rng.next() % 4);
  q.center_x = pick_coordinate(rng, r, true, pick);
  q.center_y = pick_coordinate(rng, r, false, pick == 3 ? 3 : int64_t(rng.next() % 4));
  // Radii: tiny (down to 1/256 sample), ordinary, and the configured maximum.
  switch (rng.next() % 10) {
    case 0:
    case 1: q.radius = uint32_t(1 + rng.next() % 512); break;
    case 2: q.radius = 4096u * 256u; break;
    default: q.radius = uint32_t(256 + rng.next() % (200 * 256)); break;
  }
  q.rotation = uint16_t(rng.next() % 4 == 0 ? (rng.next() % 4) * 16384 : rng.next());
  const int32_t max_units = layer_max(q.layer) - layer_min(q.layer);
  // Saturating intensities a third of the time.
  q.intensity = rng.next() % 3 == 0
                    ? (rng.next() % 2 ? 1 : -1) * max_units * 256
                    : int32_t(int64_t(rng.next() % uint64_t(2 * max_units * 256 + 1)) - max_units * 256);
  q.blend = BlendMode(rng.next() % 4);
  q.target = int32_t(layer_min(q.layer) +
                     int64_t(rng.next() % uint64_t(layer_max(q.layer) - layer_min(q.layer) + 1)));
  q.shape = uint16_t(rng.next());
  switch (q.kind) {
    case StampKind::kTexture:
      q.texture_id = texture_ids.empty() ? 0 : texture_ids[rng.next() % texture_ids.size()];
      break;
    case StampKind::kCrater:
      if (q.blend == BlendMode::kAdd || q.blend == BlendMode::kSubtract) {
        // The volume pre-pass walks the whole unclipped rect: keep it to ordinary radii.
        if (rng.next() % 2 && q.radius < 300u * 256u) q.flags = kStampFlagVolumeConserving;
      }
      break;
    case StampKind::kFootprint:
      q.blend = BlendMode::kAdd;
      q.intensity = std::abs(q.intensity);
      break;
    case StampKind::kFlatten:
      q.blend = BlendMode::kAdd;
      q.intensity = int32_t(rng.next() % 65537);
      break;
    case StampKind::kShockwave:
      q.blend = BlendMode::kAdd;
      q.radius = uint32_t(256 + rng.next() % (12 * 256));
      q.steps = uint16_t(1 + rng.next() % 40);
      q.speed = uint16_t(rng.next() % 3 == 0 ? 65535 : 1 + rng.next() % 65535);  // above the cap: sub-steps
      q.damping = uint16_t(rng.next() % 2 ? 0 : rng.next());
      break;
    default: break;
  }
  // docs/stamps.md: a field is 0 on the kinds and blends that do not use it (the draws above
  // stay, so the sequence of stamps is otherwise the same).
  if (q.kind != StampKind::kFlatten && q.blend != BlendMode::kMin && q.blend != BlendMode::kMax) q.target = 0;
  if (q.kind != StampKind::kCrater && q.kind != StampKind::kFootprint && q.kind != StampKind::kFlatten)
    q.shape = 0;
  return q;
}

}  // namespace loam
