// AVX2 kernels of the fast mode: the rANS encoder (32 symbols per step, backwards), the
// rANS token decoder (one row, 32 tokens per step, four vectors of eight states so four
// gather chains overlap) and the residual reconstruction of coarse samples (escape bits,
// zigzag, the plane predictor's running sum; eight samples per step). Each computes exactly
// what the portable loops in fast_coder.cpp compute; the caller picks them only where the
// CPU has AVX2 (codec::detected_isa()), and tests check that both paths write the same
// bytes and decode the same samples.
#pragma once

#include <cstddef>
#include <cstdint>

#include "protocol/codec/escape_bits.h"

namespace loam::codec {

// True when this build has the kernels (x86-64 with GCC or clang).
bool fast_coder_avx2_built();

// What the AVX2 encoder reads per symbol: two words, freq | (reciprocal mod 2^21) << 11 and
// start | (reciprocal >> 21) << 10 (reciprocal = ceil(2^42 / freq) as in rans.h).
struct PackedEncSymbol {
  uint32_t freq_low = 0;
  uint32_t start_high = 0;
};
PackedEncSymbol pack_enc_symbol(uint32_t start, uint32_t freq);

// Encodes symbols sym[0, n) backwards (n a multiple of rans::kLanes; symbol i with state
// i % kLanes) as rans::encode_step does. `words` points one past the lowest word written so
// far and is moved down; the kernel writes up to eight words below the last one it keeps.
void encode_symbols_avx2(const uint16_t* sym, size_t n, const PackedEncSymbol* table, uint32_t* states,
                         uint16_t*& words);

// Zigzag plane residuals of one row of 16-bit samples, each shifted right by `shift`; `up`
// is the row above (zeros for the first row). Writes z[0, width).
void plane_residual_row_avx2(const uint16_t* cur, const uint16_t* up, uint32_t width, uint32_t shift,
                             uint16_t* z);

// Contexts of one row from the tokens of the row above (residual_tokens.h), for x in
// [1, width - 1) in blocks of 32; returns the first x it did not write (the caller does
// the rest and the edges).
uint32_t context_row_avx2(const uint8_t* up, uint32_t width, uint8_t* ctx);

// Tokens of a row of 16-bit zigzag residuals z where escapes are many: every sample's
// token into t and its raw bits (none for direct tokens) to `extras`, in order. `width` is
// a multiple of 8.
void token_row_dense_avx2(const uint16_t* z, uint32_t width, uint8_t* t, EscapeBitWriter& extras);

// s[i] = (s[i] << shift) | low for i < n (restores the low bits the fast mode shifted out).
void unshift_samples_avx2(uint16_t* s, size_t n, uint32_t shift, uint32_t low);

// Decodes `width` tokens (a multiple of rans::kLanes; the row's first symbol uses state 0)
// into `tokens`, with context table `tables + (ctx[x] << kProbBits)` for symbol x. Reads
// words from `words` and advances it; requires at least 2 * width readable bytes there.
// Returns the OR of the tokens.
uint32_t decode_token_row_avx2(uint32_t* states, const uint8_t*& words, const uint32_t* tables,
                               const uint8_t* ctx, uint32_t width, uint8_t* tokens);

// row[x] = up[x] + sum over x' <= x of r(x') modulo 2^16, where r = unzigzag(z) (plus
// above[x'], then stored there, when `above` is not null) and z is the token itself or, for
// an escape, its base and raw bits read from `escapes` at bit `bit_pos` (advanced). `width` is a multiple of
// 16; 14 * width bits plus 8 bytes must be readable from bit_pos on (fast_coder.cpp pads the end of the
// section).
void residual_row_avx2(const uint8_t* tokens, uint32_t width, const uint8_t* escapes, uint64_t& bit_pos,
                       uint16_t* above, const uint16_t* up, uint16_t* row);

// Sum of the bit widths of z[0, width).
uint64_t bit_width_sum_avx2(const uint16_t* z, uint32_t width);

}  // namespace loam::codec
