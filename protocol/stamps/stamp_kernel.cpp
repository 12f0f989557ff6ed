#include "protocol/stamps/stamp_kernel.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

#include "protocol/stamps/stamp_validate.h"
#include "protocol/world.h"
#include "protocol/world_layers.h"

namespace loam {

namespace {

// Gaussian falloff exp(-12 u^2): at u = 1 it is 6.1e-6, so even the largest coarse
// amplitude (65535 units) is below half a unit at the support's edge and rounds to 0 there:
// the profile is never cut off visibly.
constexpr double kGaussianExponent = 12.0;
// Crater: bowl inside u < a, rim falling off outside (a = 5/8 is exact in binary).
constexpr double kCraterBowl = 0.625;

double gaussian(double u) { return exact_exp_neg(kGaussianExponent * u * u); }

// Crater bowl: -(1 - (u/a)^2) inside the bowl, 0 outside.
double crater_bowl(double u) {
  if (u >= kCraterBowl) return 0.0;
  const double r = u / kCraterBowl;
  return -(1.0 - r * r);
}
// Crater rim shape (1 at the crest u = a): (u/a)^4 inside, Hermite falloff (1-t)^2 (1+2t)
// outside with t = (u - a) / (1 - a), reaching 0 with zero slope at u = 1.
double crater_rim(double u) {
  if (u < kCraterBowl) {
    const double r = u / kCraterBowl;
    return r * r * r * r;
  }
  const double t = (u - kCraterBowl) / (1.0 - kCraterBowl);
  return (1.0 - t) * (1.0 - t) * (1.0 + 2.0 * t);
}

// Rounded integer division n / d (d > 0), halves away from zero.
int64_t div_round(int64_t n, int64_t d) { return n >= 0 ? (n + d / 2) / d : -((-n + d / 2) / d); }

int32_t saturate(Layer l, int64_t v) { return int32_t(std::clamp<int64_t>(v, layer_min(l), layer_max(l))); }

int32_t blend(const QuantizedStamp& q, int32_t old, int32_t delta) {
  switch (q.blend) {
    case BlendMode::kAdd: return saturate(q.layer, int64_t(old) + delta);
    case BlendMode::kSubtract: return saturate(q.layer, int64_t(old) - delta);
    case BlendMode::kMin: return std::min(old, saturate(q.layer, int64_t(q.target) + delta));
    case BlendMode::kMax: return std::max(old, saturate(q.layer, int64_t(q.target) + delta));
  }
  return old;
}

// Bilinear sample of the texture at reduced, rotated stamp coordinates; 0..65535.
uint32_t texture_value(const StampTexture& t, int32_t ur, int32_t vr, int32_t rr) {
  // Image position (pixel centers at k + 1/2) = ((ur + R) * 2W - 2R) / 4R: |num| < 2^28.
  const int32_t den = 4 * rr;
  const int32_t nx = (ur + rr) * 2 * t.width - 2 * rr;
  const int32_t ny = (vr + rr) * 2 * t.height - 2 * rr;
  const int32_t ix = int32_t(floor_div(nx, den)), iy = int32_t(floor_div(ny, den));
  const uint32_t fx = uint32_t(((nx - ix * den) << 8) / den);  // Q8 weights 0..255
  const uint32_t fy = uint32_t(((ny - iy * den) << 8) / den);
  const int32_t x0 = std::clamp(ix, 0, t.width - 1), x1 = std::clamp(ix + 1, 0, t.width - 1);
  const int32_t y0 = std::clamp(iy, 0, t.height - 1), y1 = std::clamp(iy + 1, 0, t.height - 1);
  const uint16_t* row0 = t.samples.data() + size_t(y0) * size_t(t.width);
  const uint16_t* row1 = t.samples.data() + size_t(y1) * size_t(t.width);
  const uint32_t top = row0[x0] * (256u - fx) + row0[x1] * fx;  // < 2^24
  const uint32_t bot = row1[x0] * (256u - fx) + row1[x1] * fx;
  const uint32_t v = top * (256u - fy) + bot * fy;  // <= 65535 * 65536 < 2^32
  return (v + 32768u) >> 16;
}

// round(scale · f) as bake_table rounds it: halves away from zero, by hand (no libm).
int32_t round_entry(double scale, double f) {
  const double v = scale * f;
  return v >= 0 ? int32_t(v + 0.5) : -int32_t(-v + 0.5);
}

// Flatten's weight: 1 inside, smoothstep down to 0 over the outer `soft` fraction.
double flatten_weight(double soft, double u) {
  if (soft <= 0.0) return u < 1.0 ? 1.0 : 0.0;
  const double inner = 1.0 - soft;
  if (u <= inner) return 1.0;
  const double t = (u - inner) / soft;
  return 1.0 - t * t * (3.0 - 2.0 * t);
}

// The volume-conserving crater's separate bowl and rim entries (its table is bowl + H · rim).
int32_t bowl_entry(double amp, int32_t i) {
  return round_entry(amp, crater_bowl(double(i) / double(kProfileEntries)));
}
int32_t rim_entry(int32_t i) { return round_entry(65536.0, crater_rim(double(i) / double(kProfileEntries))); }

// table_lookup over entries computed by `entry(i)` instead of read from a table (the
// volume-conserving crater's bowl and rim are separate tables that are never stored).
template <typename Entry>
int32_t lookup_entries(const Entry& entry, int32_t u_q16) {
  if (u_q16 <= 0) return entry(0);
  if (u_q16 >= kUnitQ16) return entry(kProfileEntries);
  const int32_t i = u_q16 >> kProfileFracBits;
  const int32_t f = u_q16 & ((1 << kProfileFracBits) - 1);
  const int32_t t0 = entry(i);
  if (f == 0) return t0;  // the product below is 0 whatever entry i + 1 is
  return t0 + (((entry(i + 1) - t0) * f) >> kProfileFracBits);
}

// The last tables baked on this thread, by profile, least recently used replaced first.
class ProfileTableMemo {
 public:
  const ProfileTable& table(const StampProfile& profile) {
    ++clock_;
    Slot* victim = &slots_[0];
    for (Slot& s : slots_) {
      if (s.used != 0 && s.profile == profile) {
        s.used = clock_;
        return s.table;
      }
      if (s.used < victim->used) victim = &s;
    }
    victim->profile = profile;
    for (int32_t i = 0; i <= kProfileEntries; ++i) victim->table[size_t(i)] = profile.entry(i);
    victim->used = clock_;
    return victim->table;
  }

 private:
  struct Slot {
    StampProfile profile;
    ProfileTable table{};
    uint64_t used = 0;  // 0: empty
  };
  std::array<Slot, 8> slots_{};
  uint64_t clock_ = 0;
};

// The volume-conserving crater's rim height: sum(bowl) + H · sum(rim) = 0 over the samples
// of b.rect inside the support (geometry only, never the terrain), so the material dug lands
// on the rim to within per-sample rounding. u depends on a sample's dist alone, so samples are
// counted per dist and each dist's lookups run once. H is capped at twice the depth for stamps
// too small to have a rim sample (and is 0 when none exists).
int64_t volume_conserving_rim(const BakedStamp& b) {
  const int32_t rr = b.radius_r;
  std::vector<int64_t> count(size_t(rr), 0);
  for (int64_t y = b.rect.y0; y < b.rect.y1; ++y) {
    const int64_t dy = reduce(y * 256 - b.q.center_y, b.shift);
    for (int64_t x = b.rect.x0; x < b.rect.x1; ++x) {
      const int64_t dx = reduce(x * 256 - b.q.center_x, b.shift);
      const uint32_t dist = isqrt32(uint32_t(dx * dx + dy * dy));  // < 2^29
      if (dist < uint32_t(rr)) ++count[dist];
    }
  }
  const double amp = double(b.q.intensity);
  int64_t sum_bowl = 0, sum_rim = 0;
  for (int32_t dist = 0; dist < rr; ++dist) {
    if (count[size_t(dist)] == 0) continue;
    const int32_t u = int32_t((uint32_t(dist) << 16) / uint32_t(rr));
    sum_bowl += count[size_t(dist)] * lookup_entries([&](int32_t i) { return bowl_entry(amp, i); }, u);
    sum_rim += count[size_t(dist)] * lookup_entries(rim_entry, u);
  }
  int64_t h_q8 = sum_rim > 0 ? div_round(-sum_bowl * 65536, sum_rim) : 0;
  const int64_t cap = 2 * std::abs(int64_t(b.q.intensity));
  return std::clamp(h_q8, -cap, cap);
}

}  // namespace

int32_t StampProfile::entry(int32_t i) const {
  const double u = double(i) / double(kProfileEntries);
  switch (kind) {
    case StampKind::kTexture: return round_entry(amp, u);  // intensity ramp over the image value
    case StampKind::kGaussian:
    case StampKind::kShockwave: return round_entry(amp, gaussian(u));  // shockwave: its initial pulse
    case StampKind::kCrater:
      if (volume_conserving) return int32_t(bowl_entry(amp, i) + div_round(rim_q8 * rim_entry(i), 65536));
      // Depth positive digs; the rim rises shape * depth above the surroundings.
      return round_entry(amp, crater_bowl(u) + shape * crater_rim(u));
    case StampKind::kFootprint: return round_entry(amp, shape * u * u);  // sole height above its lowest point
    case StampKind::kFlatten: return round_entry(16384.0 * (amp / 65536.0), flatten_weight(shape, u));  // Q14
  }
  return 0;
}

Result<BakedStamp> bake_stamp(const QuantizedStamp& q, const WorldParams& world,
                              const TextureRegistry* textures) {
  BakedStamp b;
  b.q = q;
  const int64_t radius = int64_t(q.radius);
  b.profile.kind = q.kind;
  b.profile.amp = double(q.intensity);
  b.profile.shape = double(q.shape) / 65536.0;
  b.support_q8 = radius;
  if (q.kind == StampKind::kTexture) {
    b.texture = textures != nullptr ? textures->find(q.texture_id) : nullptr;
    if (b.texture == nullptr) {
      return make_error(ErrorCode::kNotFound, "stamp.texture_id", "no registered texture has this id");
    }
    // The rotated square reaches radius * sqrt(2): 46341 / 32768 > sqrt(2).
    b.support_q8 = (radius * 46341 + 32767) / 32768 + 1;
    rotation_q15(q.rotation, b.cos_q15, b.sin_q15);
  }
  b.shift = reduction_shift(b.support_q8);
  b.radius_r = int32_t(std::max<int64_t>(1, radius >> b.shift));
  const RectI world_rect = layer_sample_rect(world, q.layer);
  const RectI r{ceil_div(q.center_x - b.support_q8, 256), ceil_div(q.center_y - b.support_q8, 256),
                floor_div(q.center_x + b.support_q8, 256) + 1, floor_div(q.center_y + b.support_q8, 256) + 1};
  b.rect = r.intersect(world_rect);
  if (q.kind == StampKind::kCrater && (q.flags & kStampFlagVolumeConserving) != 0) {
    b.profile.volume_conserving = true;
    b.profile.rim_q8 = volume_conserving_rim(b);
  }
  thread_local ProfileTableMemo memo;
  b.table = memo.table(b.profile);
  return b;
}

int32_t radial_u_q16(const BakedStamp& b, int64_t gx, int64_t gy) {
  if (!b.rect.contains(gx, gy)) return -1;  // offsets are only bounded inside the rect
  const int32_t dx = reduce(gx * 256 - b.q.center_x, b.shift);
  const int32_t dy = reduce(gy * 256 - b.q.center_y, b.shift);
  const uint32_t d2 = uint32_t(dx * dx + dy * dy);  // < 2^29
  const uint32_t dist = isqrt32(d2);
  if (dist >= uint32_t(b.radius_r)) return -1;
  return int32_t((dist << 16) / uint32_t(b.radius_r));  // dist < 2^14: fits
}

void footprint_contact(BakedStamp& b, const World& world) {
  b.has_contact = false;
  int32_t best = 0;
  visit_layer(b.q.layer, [&](auto row) {
    for (int64_t y = b.rect.y0; y < b.rect.y1; ++y) {
      for (int64_t x = b.rect.x0; x < b.rect.x1; ++x) {
        const int32_t u = radial_u_q16(b, x, y);
        if (u < 0) continue;
        const int32_t old = int32_t(LayerOps<decltype(row)>::sample(world, x, y));
        const int32_t c = old * 256 - table_lookup(b.table, u);
        if (!b.has_contact || c > best) best = c;
        b.has_contact = true;
      }
    }
  });
  b.contact_q8 = best;
}

int32_t stamp_sample(const BakedStamp& b, int64_t gx, int64_t gy, int32_t old) {
  const QuantizedStamp& q = b.q;
  if (q.kind == StampKind::kTexture) {
    if (!b.rect.contains(gx, gy)) return old;  // offsets are only bounded inside the rect
    const int32_t dx = reduce(gx * 256 - q.center_x, b.shift);
    const int32_t dy = reduce(gy * 256 - q.center_y, b.shift);
    // Image axes are the stamp axes rotated counter-clockwise by the rotation: sample
    // offset rotated clockwise. |products| < 2^29.
    const int32_t ur = (dx * b.cos_q15 + dy * b.sin_q15) >> 15;
    const int32_t vr = (dy * b.cos_q15 - dx * b.sin_q15) >> 15;
    if (ur <= -b.radius_r || ur >= b.radius_r || vr <= -b.radius_r || vr >= b.radius_r) return old;
    const uint32_t t = texture_value(*b.texture, ur, vr, b.radius_r);
    const int32_t u = int32_t(t + (t >> 15));  // 65535 -> 65536: white is the full intensity
    return blend(q, old, round_q8(table_lookup(b.table, u)));
  }
  const int32_t u = radial_u_q16(b, gx, gy);
  if (u < 0) return old;
  switch (q.kind) {
    case StampKind::kGaussian:
    case StampKind::kCrater: return blend(q, old, round_q8(table_lookup(b.table, u)));
    case StampKind::kFootprint: {
      if (!b.has_contact) return old;
      const int32_t sole = round_q8(b.contact_q8 - q.intensity + table_lookup(b.table, u));
      return std::min(old, saturate(q.layer, sole));
    }
    case StampKind::kFlatten: {
      const int32_t w = table_lookup(b.table, u);  // Q14
      return old + (((q.target - old) * w + 8192) >> 14);
    }
    default: return old;
  }
}

}  // namespace loam
