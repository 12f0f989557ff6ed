// The per-sample stamp kernel: what one sample becomes under a quantized stamp.
//
// bake_stamp turns a QuantizedStamp into per-stamp constants (profile table, reduction shift,
// rotation, sample rect) using only correctly rounded operations; stamp_sample is then a pure
// function of (baked stamp, global sample coordinates, old value) in 32-bit integer
// arithmetic, which the GPU shader mirrors line by line. Footprint's contact height and the
// volume-conserving crater's rim height are per-stamp constants too, found by a pre-pass
// (footprint reads the terrain; the crater only the stamp's geometry). Shockwave is not a
// per-sample kind (shockwave.h). docs/stamps.md states every formula and bit budget.
#pragma once

#include <cstdint>
#include <optional>

#include "protocol/geometry.h"
#include "protocol/result.h"
#include "protocol/stamps/stamp.h"
#include "protocol/stamps/stamp_profile.h"
#include "protocol/stamps/texture_registry.h"

namespace loam {

class World;

// What a stamp's profile table is a function of, and the table entry by entry: entry(i) is
// exactly what bake_stamp stores in table[i]. Two stamps with equal profiles have equal tables
// whatever their position and radius, which is what lets bake_stamp reuse a table.
struct StampProfile {
  StampKind kind = StampKind::kGaussian;
  double amp = 0;    // Q8 layer units (flatten: Q16 strength)
  double shape = 0;  // crater rim, footprint sole, flatten softness: shape / 65536
  bool volume_conserving = false;
  int64_t rim_q8 = 0;  // volume-conserving crater: the rim height found from the stamp's samples
  int32_t entry(int32_t i) const;
  friend bool operator==(const StampProfile&, const StampProfile&) = default;
};

struct BakedStamp {
  QuantizedStamp q;
  ProfileTable table{};     // kind-specific, see docs/stamps.md
  int64_t support_q8 = 0;   // half side of the square around the center that may change (Q8)
  RectI rect;               // layer samples that may change, clipped to the world (may be empty)
  int32_t shift = 0;        // reduction shift s: offsets are reduced to |d >> s| < 2^14
  int32_t radius_r = 1;     // reduced radius max(1, radius >> s)
  int32_t cos_q15 = 32768;  // texture rotation
  int32_t sin_q15 = 0;
  const StampTexture* texture = nullptr;
  int32_t contact_q8 = 0;    // footprint: first point of contact (layer units, Q8)
  bool has_contact = false;  // footprint: some sample lies under the foot
  StampProfile profile;      // what `table` is a function of
};

// Bakes everything that depends on the stamp alone. The stamp must have passed
// check_quantized; a texture stamp needs its texture in `textures` (error otherwise).
// Footprint contact is filled by footprint_contact() (stamp_apply does it).
// The table comes from a per-thread memo of the last tables baked, by profile (players repeat
// their stamps: every footprint of a walk, every shell of a weapon; a Gaussian table costs
// 1025 exp series, 20 us). A table is a pure function of its profile, so a reused table is
// bit for bit a fresh one (tested).
Result<BakedStamp> bake_stamp(const QuantizedStamp& q, const WorldParams& world,
                              const TextureRegistry* textures = nullptr);

// Footprint pre-pass: the contact height max(old_q8 - sole(u)) over the samples under the
// foot, read from the world's layer. Sets b.contact_q8 / b.has_contact.
void footprint_contact(BakedStamp& b, const World& world);

// Normalized radial coordinate of a sample: u in Q16 (65536 = the radius), or -1 outside
// the support (u >= 1) or outside b.rect. 32-bit only: |dxr|, |dyr| < 2^14, d2 < 2^29.
int32_t radial_u_q16(const BakedStamp& b, int64_t gx, int64_t gy);

// New value of the sample at global layer coordinates (gx, gy) holding `old`. Samples
// outside the stamp's support or its rect return `old`. Not for shockwave stamps.
int32_t stamp_sample(const BakedStamp& b, int64_t gx, int64_t gy, int32_t old);

}  // namespace loam
