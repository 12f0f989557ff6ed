// The fast CPU stamp kernel: exactly the integers of stamp_sample, at memory speed.
//
// stamp_sample (stamp_kernel.h) is the definition: one sample at a time, from scratch. The
// fast path computes the same function row span by row span, relying on three facts that
// docs/stamps.md ("The fast path") proves:
//  - a radial sample's new value depends only on dist = isqrt(dxr² + dyr²), so one table of
//    the final per-dist value (delta, saturated target, sole or weight) replaces the
//    division, the profile interpolation and the rounding of every sample;
//  - the samples of a row inside the disc form one run whose ends follow exactly from the
//    integer disc test (no sample outside it is visited);
//  - isqrt of a 29-bit integer is the float square root truncated and corrected by at most
//    one, checked with exact 32-bit squares (AVX2, eight samples at a time, where the CPU
//    has it; the portable loop uses the exact double square root).
// Texture stamps use per-axis tables of the bilinear position and weights when the stamp is
// large enough to pay for them, else stamp_sample itself. Shockwave is not a per-sample kind
// and is not handled here. Results are identical for every ISA choice (tested).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "protocol/geometry.h"
#include "protocol/stamps/stamp_kernel.h"

namespace loam {

// Which instruction set the fast kernel uses. kBest picks AVX2 where the CPU has it and skips
// the per-stamp tables where a stamp is too small to pay for them. Naming an ISA forces the
// tables (and that ISA, where the CPU has it) so tests reach every code path on every stamp;
// kAvx2Direct forces AVX2 without the per-dist table (each sample's value computed from the
// profile table, as kBest does for stamps smaller than their per-dist table).
enum class FastIsa : uint8_t { kBest = 0, kPortable = 1, kAvx2 = 2, kAvx2Direct = 3 };

// floor(n / d) for n < 2^30 and 1 <= d < 2^15 by one multiply and a shift (Granlund and
// Montgomery's round-up method: m = ceil(2^k / d), k = 30 + ceil(log2 d), so m·d − 2^k < d
// <= 2^(k−30) and the error never reaches the next integer). The kernel's per-sample
// u = (dist << 16) / Rr without a division; exact for every d (tested).
struct ExactDivisor {
  explicit ExactDivisor(uint32_t d);
  uint32_t divide(uint32_t n) const { return uint32_t((uint64_t(n) * m) >> k); }
  uint64_t m = 1;  // < 2^32
  uint32_t k = 0;
};

// True when this build and this CPU can run `isa` (kBest and kPortable always can).
bool fast_isa_available(FastIsa isa);

// isqrt of each value (< 2^29) exactly as the kernel of `isa` computes it for a sample; for
// tests, which check it against isqrt32 next to every perfect square. Spans of equal size.
void fast_isqrt_for_test(std::span<const uint32_t> in, std::span<uint32_t> out, FastIsa isa);

// Per-stamp state of the fast kernel, prepared once from a baked stamp (which must outlive
// it; footprint contact must already be filled in) and then run tile by tile.
class FastStamp {
 public:
  // Not for shockwave stamps (nothing is changed for them).
  explicit FastStamp(const BakedStamp& b, FastIsa isa = FastIsa::kBest);

  // Which kernel runs (for tests and the bench): AVX2 rows, and whether tables were built.
  bool uses_avx2() const { return avx2_; }
  bool uses_tables() const { return !by_dist_.empty() || !tex_x_.empty(); }

  // Applies the stamp to the part of b.rect inside tile (tx, ty), whose kTileSamples
  // row-major samples are `tile`, and returns the bounding rect (global layer coordinates)
  // of the samples that changed: exactly what the reference loop does and returns.
  RectI apply_in_tile(uint16_t* tile, int64_t tx, int64_t ty) const;
  RectI apply_in_tile(int8_t* tile, int64_t tx, int64_t ty) const;

  // How a sample combines its old value with the per-dist table value v.
  enum class Op : uint8_t {
    kNone,     // nothing changes (footprint with no contact, shockwave)
    kAddSat,   // clamp(old + v) to the layer range: add and subtract (v negated)
    kMin,      // min(old, v): min blend, footprint
    kMax,      // max(old, v)
    kFlatten,  // old + (((target - old) * v + 8192) >> 14)
  };

 private:
  template <typename T>
  RectI apply_radial(T* tile, int64_t tx, int64_t ty) const;
  template <typename T>
  RectI apply_texture(T* tile, int64_t tx, int64_t ty) const;
  int32_t value_at_dist(int32_t dist) const;
  int32_t value_at_dist_u(int32_t u_q16) const;
  int32_t value_of(int32_t t) const;

  const BakedStamp& b_;
  Op op_ = Op::kNone;
  bool avx2_ = false;
  int32_t lo_ = 0, hi_ = 0;  // layer range
  ExactDivisor per_rr_{1};   // u = (dist << 16) / Rr
  // How every kind turns the profile table's t into what it combines with the old value:
  // v = clamp(sign · ((t + base + 128) >> 8) + offset, vlo, vhi), or v = t (flatten's weight).
  struct ValueForm {
    int32_t base = 0, sign = 1, offset = 0, vlo = 0, vhi = 0;
    bool raw = false;
    int32_t neutral = 0;  // leaves an old value unchanged under op_ (lanes past the disc)
  };
  ValueForm form_;
  // Radial: the value for every dist in [0, radius_r), or empty when the stamp has fewer
  // samples than the table would have entries (then value_at_dist runs per sample).
  // Entry radius_r leaves a sample unchanged (vector rows padded past the disc).
  std::vector<int32_t> by_dist_;
  // With the table: each row's disc span [x0, x1) within the rect and its |dyr|.
  struct RowSpan {
    int64_t x0, x1;
    int32_t b_abs;
  };
  std::vector<RowSpan> rows_;
  // Texture: for each reduced rotated coordinate ur (vr) in (-Rr, Rr), the clamped image
  // columns (rows) and the Q8 weight of the second, as texture_value computes them.
  struct Axis {
    int32_t i0, i1;
    uint32_t f;
  };
  std::vector<Axis> tex_x_, tex_y_;
};

// Footprint pre-pass over the world: the same contact as footprint_contact() (stamp_kernel.h),
// visiting only the samples under the foot.
void footprint_contact_fast(BakedStamp& b, const World& world);

}  // namespace loam
