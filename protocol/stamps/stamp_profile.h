// Stamp profile tables and the exact arithmetic every backend shares.
//
// A stamp's shape is baked once per stamp into a small integer table (kProfileEntries + 1
// int32 entries) from its quantized parameters only, using nothing but correctly rounded
// IEEE operations (+ - * / sqrt) in a fixed order, compiled with -ffp-contract=off: exp,
// cos and sin are our own series below, never libm, whose last bit differs by platform.
// Per sample, backends then use only 32-bit integer arithmetic: the helpers here (isqrt,
// table_lookup, reduce) are the reference the GPU shader mirrors. docs/stamps.md gives the
// bit budgets. Pure functions: safe on any input.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

namespace loam {

// Table resolution: the normalized coordinate u in [0, 1] is Q16 (0..65536); the table has
// one entry per 1/1024 and is interpolated linearly with 6-bit weights.
inline constexpr int32_t kProfileEntriesLog2 = 10;
inline constexpr int32_t kProfileEntries = 1 << kProfileEntriesLog2;
inline constexpr int32_t kProfileFracBits = 16 - kProfileEntriesLog2;  // 6
inline constexpr int32_t kUnitQ16 = 65536;

using ProfileTable = std::array<int32_t, kProfileEntries + 1>;

// Reduced stamp-relative coordinates stay below 2^kReducedBits in magnitude (see reduce()).
inline constexpr int32_t kReducedBits = 14;

// exp(-x) for x >= 0 in double using only + - * /: Taylor series of exp(-x / 2^k) with
// |x / 2^k| <= 1/16, then k squarings. Deterministic across IEEE-754 platforms.
double exact_exp_neg(double x);

// cos and sin of a quantized rotation (1/65536 turn), in Q15 (-32768..32768), rounded to
// nearest; exact at multiples of a quarter turn; sin^2 + cos^2 within 2 units of 2^30.
void rotation_q15(uint16_t rotation, int32_t& cos_q15, int32_t& sin_q15);

// Floor of the square root of an unsigned 32-bit integer, exactly.
uint32_t isqrt32(uint32_t v);

// The shift that brings a Q8 extent below 2^kReducedBits: smallest s >= 0 with
// (extent_q8 >> s) < 2^kReducedBits.
int32_t reduction_shift(int64_t extent_q8);

// Reduces a stamp-relative Q8 offset by 2^s, truncating toward zero so the reduction is
// symmetric under mirroring and quarter turns: sign(d) * (|d| >> s).
inline int32_t reduce(int64_t d_q8, int32_t s) {
  return d_q8 < 0 ? -int32_t((-d_q8) >> s) : int32_t(d_q8 >> s);
}

// Linear interpolation in a profile table at u (Q16, clamped to [0, 65536]):
// T[i] + floor((T[i+1] - T[i]) * f / 64) with i = u >> 6, f = u & 63. The product fits
// int32 when adjacent entries differ by less than 2^25 (true for every baked table).
inline int32_t table_lookup(const ProfileTable& t, int32_t u_q16) {
  if (u_q16 <= 0) return t[0];
  if (u_q16 >= kUnitQ16) return t[kProfileEntries];
  const int32_t i = u_q16 >> kProfileFracBits;
  const int32_t f = u_q16 & ((1 << kProfileFracBits) - 1);
  return t[size_t(i)] + (((t[size_t(i) + 1] - t[size_t(i)]) * f) >> kProfileFracBits);
}

// Rounds a Q8 value to the nearest integer, halves toward +infinity: floor((v + 128) / 256).
inline int32_t round_q8(int32_t v) { return (v + 128) >> 8; }

// Bakes table[i] = round(scale * f(i / kProfileEntries)) for a profile f given as a
// function of u in [0, 1]. `f` must itself use only + - * / sqrt and the functions above.
template <typename F>
ProfileTable bake_table(double scale, F f) {
  ProfileTable t{};
  for (int32_t i = 0; i <= kProfileEntries; ++i) {
    const double u = double(i) / double(kProfileEntries);
    const double v = scale * f(u);
    // Round half away from zero by hand (no libm): values are far below 2^31.
    t[size_t(i)] = v >= 0 ? int32_t(v + 0.5) : -int32_t(-v + 0.5);
  }
  return t;
}

}  // namespace loam
