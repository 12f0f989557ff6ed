// How the fast mode turns a zigzag residual into an entropy-coded token plus raw bits, and
// which context codes each token. Pure arithmetic, safe on any input.
//
// A residual z (zigzag-mapped, z < 2^bits) below 32 is its own token. Larger ones are coded
// like a float with a two-bit mantissa: with b = bit_width(z) (6..bits), the token is
// 32 + 2(b - 6) + (bit b-2 of z), and the b - 2 bits below it follow as raw bits. So a
// 16-bit residual is one of 54 tokens (an 8-bit one of 38), small residuals are coded
// exactly, and the rare large ones cost a few raw bits more than their entropy.
//
// The context of a sample is its activity from the row above, which the decoder knows
// before it decodes the row: a = 2 t(N) + t(NW) + t(NE) over the tokens of the row above
// (columns clamped to the rect), quantized to kContexts classes by kContextThresholds. The
// first row, which has no row above and holds the horizontal differences of the rect's
// edge, uses the last (widest) class.
#pragma once

#include <bit>
#include <cstdint>

namespace loam::codec {

inline constexpr uint32_t kDirectTokens = 32;
// Tokens of a `bits`-bit residual: 32 direct, then two per bit width 6..bits.
inline constexpr uint32_t token_count(int bits) { return kDirectTokens + 2 * uint32_t(bits - 5); }
inline constexpr uint32_t kMaxTokens = token_count(16);  // 54

constexpr uint32_t token_of(uint32_t z) {
  if (z < kDirectTokens) return z;
  const uint32_t b = uint32_t(std::bit_width(z));
  return kDirectTokens + 2 * (b - 6) + ((z >> (b - 2)) & 1u);
}
// Raw bits after token t (0 for direct tokens).
constexpr uint32_t token_extra_bits(uint32_t t) {
  return t < kDirectTokens ? 0 : 4 + ((t - kDirectTokens) >> 1);
}
// z from an escape token (t >= 32) and its raw bits.
constexpr uint32_t residual_of(uint32_t t, uint32_t extra) {
  const uint32_t n = token_extra_bits(t);
  return ((2u | (t & 1u)) << n) | extra;
}

inline constexpr int kContexts = 8;
inline constexpr int kFirstRowContext = kContexts - 1;
// Class k (1..7) starts at activity kContextThresholds[k - 1].
inline constexpr uint8_t kContextThresholds[kContexts - 1] = {2, 4, 8, 14, 24, 40, 64};
// a = 2 t(N) + t(NW) + t(NE) <= 4 * 53 fits a byte. Written out so that it vectorizes.
constexpr uint8_t context_of(uint8_t a) {
  static_assert(kContextThresholds[0] == 2 && kContextThresholds[6] == 64);
  return uint8_t((a >= 2) + (a >= 4) + (a >= 8) + (a >= 14) + (a >= 24) + (a >= 40) + (a >= 64));
}

}  // namespace loam::codec
