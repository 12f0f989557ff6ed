#include "protocol/codec/fast_coder_avx2.h"

#include <array>
#include <bit>
#include <cstring>

#include "protocol/codec/rans.h"
#include "protocol/codec/residual_tokens.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define LOAM_FAST_CODER_AVX2 1
#include <immintrin.h>
#endif

namespace loam::codec {

PackedEncSymbol pack_enc_symbol(uint32_t start, uint32_t freq) {
  const uint64_t reciprocal = ((uint64_t(1) << rans::kReciprocalShift) + freq - 1) / freq;
  return {freq | uint32_t((reciprocal & ((1u << 21) - 1)) << 11), start | uint32_t((reciprocal >> 21) << 10)};
}

#ifdef LOAM_FAST_CODER_AVX2

namespace {

// For each 8-bit mask of lanes that emit a word: the emitting lanes in lane order, placed
// at the top of the eight positions (the encoder writes downwards, lane 0's word lowest).
struct EmitPermutes {
  alignas(32) std::array<std::array<uint32_t, 8>, 256> index{};
};
constexpr EmitPermutes make_emit_permutes() {
  EmitPermutes p{};
  for (uint32_t m = 0; m < 256; ++m) {
    const uint32_t count = uint32_t(std::popcount(m));
    uint32_t k = 8 - count;
    for (uint32_t j = 0; j < 8; ++j)
      if ((m >> j) & 1u) p.index[m][k++] = j;
  }
  return p;
}
constexpr EmitPermutes kEmitPermutes = make_emit_permutes();

// Eight lanes of floor(x * r / 2^42) with r = high * 2^21 + low (high <= 2^21, low < 2^21),
// x < 2^32: as (x * high + ((x * low) >> 21)) >> 21, each product exact in 64 bits.
__attribute__((target("avx2"))) inline __m256i quotient8(__m256i x, __m256i high, __m256i low) {
  const __m256i even = _mm256_srli_epi64(
      _mm256_add_epi64(_mm256_mul_epu32(x, high), _mm256_srli_epi64(_mm256_mul_epu32(x, low), 21)), 21);
  const __m256i xo = _mm256_srli_epi64(x, 32);
  const __m256i odd = _mm256_srli_epi64(
      _mm256_add_epi64(_mm256_mul_epu32(xo, _mm256_srli_epi64(high, 32)),
                       _mm256_srli_epi64(_mm256_mul_epu32(xo, _mm256_srli_epi64(low, 32)), 21)),
      21);
  return _mm256_blend_epi32(even, _mm256_slli_epi64(odd, 32), 0xAA);
}

// One vector of eight states, lanes 7 down to 0 as the scalar encoder orders them.
__attribute__((target("avx2"))) inline __m256i encode8(__m256i x, const uint16_t* sym,
                                                       const PackedEncSymbol* table, uint16_t*& words) {
  const __m256i idx =
      _mm256_slli_epi32(_mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(sym))), 1);
  const int* base = reinterpret_cast<const int*>(table);
  const __m256i a = _mm256_i32gather_epi32(base, idx, 4);
  const __m256i b = _mm256_i32gather_epi32(base + 1, idx, 4);
  const __m256i freq = _mm256_and_si256(a, _mm256_set1_epi32(2047));
  const __m256i low = _mm256_srli_epi32(a, 11);
  const __m256i start = _mm256_and_si256(b, _mm256_set1_epi32(1023));
  const __m256i high = _mm256_srli_epi32(b, 10);
  // emit when x > (freq << 22) - 1, i.e. x >= freq << 22 (0 for freq 1024: never).
  const __m256i limit = _mm256_sub_epi32(_mm256_slli_epi32(freq, 22), _mm256_set1_epi32(1));
  const __m256i bias = _mm256_set1_epi32(int(0x80000000u));
  const __m256i emit = _mm256_cmpgt_epi32(_mm256_xor_si256(x, bias), _mm256_xor_si256(limit, bias));
  const uint32_t m = uint32_t(_mm256_movemask_ps(_mm256_castsi256_ps(emit)));
  const __m256i perm = _mm256_load_si256(reinterpret_cast<const __m256i*>(kEmitPermutes.index[m].data()));
  const __m256i low_halves = _mm256_setr_epi8(0, 1, 4, 5, 8, 9, 12, 13, -1, -1, -1, -1, -1, -1, -1, -1, 0, 1,
                                              4, 5, 8, 9, 12, 13, -1, -1, -1, -1, -1, -1, -1, -1);
  const __m256i packed =
      _mm256_permute4x64_epi64(_mm256_shuffle_epi8(_mm256_permutevar8x32_epi32(x, perm), low_halves), 0x08);
  _mm_storeu_si128(reinterpret_cast<__m128i*>(words - 8), _mm256_castsi256_si128(packed));
  words -= std::popcount(m);
  x = _mm256_blendv_epi8(x, _mm256_srli_epi32(x, 16), emit);
  const __m256i q = quotient8(x, high, low);
  const __m256i complement = _mm256_sub_epi32(_mm256_set1_epi32(int(rans::kProbScale)), freq);
  return _mm256_add_epi32(_mm256_add_epi32(x, start), _mm256_mullo_epi32(q, complement));
}

// For each 8-bit mask of lanes that take a word: lane j gets the index of its word among
// the ones read (the number of set bits below j), so a permute hands out the next words in
// lane order, exactly as the scalar decoder consumes them.
struct RefillPermutes {
  alignas(32) std::array<std::array<uint32_t, 8>, 256> index{};
};
constexpr RefillPermutes make_refill_permutes() {
  RefillPermutes p{};
  for (uint32_t m = 0; m < 256; ++m) {
    uint32_t k = 0;
    for (uint32_t j = 0; j < 8; ++j) {
      p.index[m][j] = (m >> j) & 1u ? k : 0;
      if ((m >> j) & 1u) ++k;
    }
  }
  return p;
}
constexpr RefillPermutes kRefillPermutes = make_refill_permutes();

static_assert(rans::kLanes == 32, "the kernel keeps four vectors of eight states");

// One vector of eight states: decodes the symbols at ctx[0..8) and refills from `words`.
__attribute__((target("avx2"))) inline __m256i decode8(__m256i x, const uint8_t*& words,
                                                       const uint32_t* tables, const uint8_t* ctx,
                                                       __m256i& symbols) {
  const __m256i slot_mask = _mm256_set1_epi32(int(rans::kProbScale - 1));
  const __m256i c = _mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(ctx)));
  const __m256i idx =
      _mm256_or_si256(_mm256_slli_epi32(c, int(rans::kProbBits)), _mm256_and_si256(x, slot_mask));
  const __m256i e = _mm256_i32gather_epi32(reinterpret_cast<const int*>(tables), idx, 4);
  const __m256i freq = _mm256_srli_epi32(e, 18);
  const __m256i bias = _mm256_and_si256(_mm256_srli_epi32(e, 8), slot_mask);
  x = _mm256_add_epi32(_mm256_mullo_epi32(freq, _mm256_srli_epi32(x, int(rans::kProbBits))), bias);
  symbols = _mm256_and_si256(e, _mm256_set1_epi32(0xFF));
  const __m256i need = _mm256_cmpeq_epi32(_mm256_srli_epi32(x, 16), _mm256_setzero_si256());
  const uint32_t m = uint32_t(_mm256_movemask_ps(_mm256_castsi256_ps(need)));
  const __m256i w = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(words)));
  const __m256i perm = _mm256_load_si256(reinterpret_cast<const __m256i*>(kRefillPermutes.index[m].data()));
  const __m256i refilled = _mm256_or_si256(_mm256_slli_epi32(x, 16), _mm256_permutevar8x32_epi32(w, perm));
  words += 2 * uint32_t(__builtin_popcount(m));
  return _mm256_blendv_epi8(x, refilled, need);
}

// Inclusive prefix sum of eight 32-bit lanes.
__attribute__((target("avx2"))) inline __m256i prefix_sum8(__m256i v) {
  v = _mm256_add_epi32(v, _mm256_slli_si256(v, 4));
  v = _mm256_add_epi32(v, _mm256_slli_si256(v, 8));
  const __m256i low_total = _mm256_permutevar8x32_epi32(v, _mm256_set1_epi32(3));
  return _mm256_add_epi32(v, _mm256_blend_epi32(_mm256_setzero_si256(), low_total, 0xF0));
}

__attribute__((target("avx2"))) inline __m256i load_shifted16(const uint16_t* p, __m128i count) {
  return _mm256_srl_epi16(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(p)), count);
}

// z[x, x + 16) of plane_residual_row_avx2 (x >= 1).
__attribute__((target("avx2"))) inline void residual_block16(const uint16_t* cur, const uint16_t* up,
                                                             uint32_t x, __m128i count, uint16_t* z) {
  const __m256i d = _mm256_sub_epi16(load_shifted16(cur + x, count), load_shifted16(up + x, count));
  const __m256i dw = _mm256_sub_epi16(load_shifted16(cur + x - 1, count), load_shifted16(up + x - 1, count));
  const __m256i r = _mm256_sub_epi16(d, dw);
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(z + x),
                      _mm256_xor_si256(_mm256_slli_epi16(r, 1), _mm256_srai_epi16(r, 15)));
}

// ctx[x, x + 32) of context_row_avx2 (1 <= x, x + 33 <= width).
__attribute__((target("avx2"))) inline void context_block32(const uint8_t* up, uint32_t x, uint8_t* ctx) {
  const __m256i u = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(up + x));
  const __m256i l = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(up + x - 1));
  const __m256i r = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(up + x + 1));
  const __m256i a = _mm256_add_epi8(_mm256_add_epi8(u, u), _mm256_add_epi8(l, r));  // <= 212: no wrap
  __m256i c = _mm256_setzero_si256();
  for (uint8_t t : kContextThresholds) {
    const __m256i at_least = _mm256_cmpeq_epi8(_mm256_max_epu8(a, _mm256_set1_epi8(char(t))), a);
    c = _mm256_sub_epi8(c, at_least);
  }
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(ctx + x), c);
}

// The residuals z of eight tokens (the low 8 bytes of t8) in 32-bit lanes: the token itself,
// or for an escape its base and raw bits read at bit `pos` of `escapes` (advanced).
__attribute__((target("avx2"))) inline __m256i residuals8(__m128i t8, const uint8_t* escapes, uint64_t& pos) {
  const __m256i one = _mm256_set1_epi32(1);
  const __m256i t = _mm256_cvtepu8_epi32(t8);
  const __m256i esc = _mm256_cmpgt_epi32(t, _mm256_set1_epi32(int(kDirectTokens) - 1));
  if (_mm256_testz_si256(esc, esc)) return t;
  // bits = 4 + (t - 32) / 2, base = (2 | (t & 1)) << bits for escapes (residual_tokens.h).
  const __m256i bits =
      _mm256_and_si256(esc, _mm256_add_epi32(_mm256_srli_epi32(_mm256_sub_epi32(t, _mm256_set1_epi32(32)), 1),
                                             _mm256_set1_epi32(4)));
  const __m256i base =
      _mm256_sllv_epi32(_mm256_or_si256(_mm256_and_si256(t, one), _mm256_set1_epi32(2)), bits);
  const __m256i ends = prefix_sum8(bits);
  const __m256i offs = _mm256_add_epi32(_mm256_sub_epi32(ends, bits), _mm256_set1_epi32(int(pos & 7)));
  const __m256i raw = _mm256_i32gather_epi32(reinterpret_cast<const int*>(escapes + (pos >> 3)),
                                             _mm256_srli_epi32(offs, 3), 1);
  const __m256i mask = _mm256_sub_epi32(_mm256_sllv_epi32(one, bits), one);
  const __m256i v =
      _mm256_and_si256(_mm256_srlv_epi32(raw, _mm256_and_si256(offs, _mm256_set1_epi32(7))), mask);
  pos += uint32_t(_mm256_extract_epi32(ends, 7));
  return _mm256_blendv_epi8(t, _mm256_or_si256(base, v), esc);
}

}  // namespace

bool fast_coder_avx2_built() { return true; }

__attribute__((target("avx2"))) void plane_residual_row_avx2(const uint16_t* cur, const uint16_t* up,
                                                             uint32_t width, uint32_t shift, uint16_t* z) {
  const __m128i count = _mm_cvtsi32_si128(int(shift));
  auto zig = [](uint32_t r) { return uint16_t(uint16_t(r << 1) ^ uint16_t(int16_t(uint16_t(r)) >> 15)); };
  z[0] = zig(uint32_t(uint16_t(cur[0] >> shift) - uint16_t(up[0] >> shift)));
  // Blocks of 16 from x = 1; the last block ends at the row's end, overlapping the one
  // before it (same values written twice).
  uint32_t x = 1;
  for (; x + 16 <= width; x += 16) residual_block16(cur, up, x, count, z);
  if (x < width && width >= 17) {
    residual_block16(cur, up, width - 16, count, z);
    x = width;
  }
  for (; x < width; ++x) {
    const uint32_t d = uint16_t(uint16_t(cur[x] >> shift) - uint16_t(up[x] >> shift));
    const uint32_t dw = uint16_t(uint16_t(cur[x - 1] >> shift) - uint16_t(up[x - 1] >> shift));
    z[x] = zig(d - dw);
  }
}

__attribute__((target("avx2"))) uint32_t context_row_avx2(const uint8_t* up, uint32_t width, uint8_t* ctx) {
  uint32_t x = 1;
  for (; x + 33 <= width; x += 32) context_block32(up, x, ctx);
  if (x + 1 < width && width >= 34) {  // the last block ends at width - 1, overlapping
    context_block32(up, width - 33, ctx);
    x = width - 1;
  }
  return x;
}

__attribute__((target("avx2"))) void token_row_dense_avx2(const uint16_t* z, uint32_t width, uint8_t* t,
                                                          EscapeBitWriter& extras) {
  const __m256i direct_max = _mm256_set1_epi32(int(kDirectTokens) - 1);
  const __m256i one = _mm256_set1_epi32(1);
  const __m256i low_dwords = _mm256_set1_epi64x(0xFFFFFFFF);
  for (uint32_t x = 0; x < width; x += 8) {
    const __m256i v = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(z + x)));
    const __m256i esc = _mm256_cmpgt_epi32(v, direct_max);
    // bit_width(v) from the exponent of v as a float (exact below 2^24).
    const __m256i b = _mm256_sub_epi32(_mm256_srli_epi32(_mm256_castps_si256(_mm256_cvtepi32_ps(v)), 23),
                                       _mm256_set1_epi32(126));
    const __m256i bits = _mm256_and_si256(esc, _mm256_sub_epi32(b, _mm256_set1_epi32(2)));
    // token 32 + 2 (b - 6) + (bit b-2 of v) = 2b + 20 + that bit
    const __m256i mant =
        _mm256_and_si256(_mm256_srlv_epi32(v, _mm256_sub_epi32(b, _mm256_set1_epi32(2))), one);
    const __m256i k_esc =
        _mm256_add_epi32(_mm256_add_epi32(_mm256_add_epi32(b, b), _mm256_set1_epi32(20)), mant);
    const __m256i k = _mm256_blendv_epi8(v, k_esc, esc);
    const __m256i bytes = _mm256_packus_epi16(_mm256_packus_epi32(k, k), _mm256_setzero_si256());
    // bytes 0-3 in the low half, 4-7 in the high half
    const uint32_t lo = uint32_t(_mm_cvtsi128_si32(_mm256_castsi256_si128(bytes)));
    const uint32_t hi = uint32_t(_mm_cvtsi128_si32(_mm256_extracti128_si256(bytes, 1)));
    std::memcpy(t + x, &lo, 4);
    std::memcpy(t + x + 4, &hi, 4);
    // Raw bits: pairs of lanes, then pairs of pairs, into two chunks of at most 56 bits.
    const __m256i val = _mm256_and_si256(v, _mm256_sub_epi32(_mm256_sllv_epi32(one, bits), one));
    const __m256i pair_v =
        _mm256_or_si256(_mm256_and_si256(val, low_dwords),
                        _mm256_sllv_epi64(_mm256_srli_epi64(val, 32), _mm256_and_si256(bits, low_dwords)));
    const __m256i pair_b = _mm256_add_epi64(_mm256_and_si256(bits, low_dwords), _mm256_srli_epi64(bits, 32));
    const __m256i quad_v =
        _mm256_or_si256(pair_v, _mm256_sllv_epi64(_mm256_unpackhi_epi64(pair_v, pair_v), pair_b));
    const __m256i quad_b = _mm256_add_epi64(pair_b, _mm256_unpackhi_epi64(pair_b, pair_b));
    const __m128i qv_hi = _mm256_extracti128_si256(quad_v, 1);
    const __m128i qb_hi = _mm256_extracti128_si256(quad_b, 1);
    extras.put(uint64_t(_mm_cvtsi128_si64(_mm256_castsi256_si128(quad_v))),
               uint32_t(_mm_cvtsi128_si64(_mm256_castsi256_si128(quad_b))));
    extras.put(uint64_t(_mm_cvtsi128_si64(qv_hi)), uint32_t(_mm_cvtsi128_si64(qb_hi)));
  }
}

__attribute__((target("avx2"))) void encode_symbols_avx2(const uint16_t* sym, size_t n,
                                                         const PackedEncSymbol* table, uint32_t* states,
                                                         uint16_t*& words) {
  __m256i x0 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(states));
  __m256i x1 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(states + 8));
  __m256i x2 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(states + 16));
  __m256i x3 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(states + 24));
  uint16_t* w = words;
  for (size_t i = n; i > 0; i -= 32) {
    const uint16_t* g = sym + i - 32;
    x3 = encode8(x3, g + 24, table, w);
    x2 = encode8(x2, g + 16, table, w);
    x1 = encode8(x1, g + 8, table, w);
    x0 = encode8(x0, g, table, w);
  }
  words = w;
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(states), x0);
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(states + 8), x1);
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(states + 16), x2);
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(states + 24), x3);
}

__attribute__((target("avx2"))) uint32_t decode_token_row_avx2(uint32_t* states, const uint8_t*& words,
                                                               const uint32_t* tables, const uint8_t* ctx,
                                                               uint32_t width, uint8_t* tokens) {
  __m256i x0 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(states));
  __m256i x1 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(states + 8));
  __m256i x2 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(states + 16));
  __m256i x3 = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(states + 24));
  const uint8_t* p = words;
  __m256i any = _mm256_setzero_si256();
  // packus works within 128-bit halves; this restores symbol order after two packs.
  const __m256i order = _mm256_setr_epi32(0, 4, 1, 5, 2, 6, 3, 7);
  for (uint32_t x = 0; x < width; x += 32) {
    __m256i s0, s1, s2, s3;
    x0 = decode8(x0, p, tables, ctx + x, s0);
    x1 = decode8(x1, p, tables, ctx + x + 8, s1);
    x2 = decode8(x2, p, tables, ctx + x + 16, s2);
    x3 = decode8(x3, p, tables, ctx + x + 24, s3);
    const __m256i bytes = _mm256_packus_epi16(_mm256_packus_epi32(s0, s1), _mm256_packus_epi32(s2, s3));
    const __m256i ordered = _mm256_permutevar8x32_epi32(bytes, order);
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(tokens + x), ordered);
    any = _mm256_or_si256(any, ordered);
  }
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(states), x0);
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(states + 8), x1);
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(states + 16), x2);
  _mm256_storeu_si256(reinterpret_cast<__m256i*>(states + 24), x3);
  words = p;
  // Tokens are below 64: any token's bit 5 survives the OR of all bytes.
  alignas(32) uint8_t b[32];
  _mm256_store_si256(reinterpret_cast<__m256i*>(b), any);
  uint32_t r = 0;
  for (uint8_t v : b) r |= v;
  return r;
}

__attribute__((target("avx2"))) uint64_t bit_width_sum_avx2(const uint16_t* z, uint32_t width) {
  // bit_width(v) = exponent of v as a float - 126 for v >= 1, 0 for v = 0.
  const __m256i bias = _mm256_set1_epi32(126);
  __m256i sum = _mm256_setzero_si256();
  uint32_t x = 0;
  for (; x + 8 <= width; x += 8) {
    const __m256i v = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(z + x)));
    const __m256i e = _mm256_srli_epi32(_mm256_castps_si256(_mm256_cvtepi32_ps(v)), 23);
    sum = _mm256_add_epi32(sum, _mm256_max_epi32(_mm256_sub_epi32(e, bias), _mm256_setzero_si256()));
  }
  alignas(32) uint32_t lanes[8];
  _mm256_store_si256(reinterpret_cast<__m256i*>(lanes), sum);
  uint64_t total = 0;
  for (uint32_t v : lanes) total += v;
  for (; x < width; ++x) total += uint64_t(std::bit_width(uint32_t(z[x])));
  return total;
}

__attribute__((target("avx2"))) void unshift_samples_avx2(uint16_t* s, size_t n, uint32_t shift,
                                                          uint32_t low) {
  const __m128i count = _mm_cvtsi32_si128(int(shift));
  const __m256i bits = _mm256_set1_epi16(short(low));
  size_t i = 0;
  for (; i + 16 <= n; i += 16) {
    __m256i* p = reinterpret_cast<__m256i*>(s + i);
    _mm256_storeu_si256(p, _mm256_or_si256(_mm256_sll_epi16(_mm256_loadu_si256(p), count), bits));
  }
  for (; i < n; ++i) s[i] = uint16_t((uint32_t(s[i]) << shift) | low);
}

__attribute__((target("avx2"))) void residual_row_avx2(const uint8_t* tokens, uint32_t width,
                                                       const uint8_t* escapes, uint64_t& bit_pos,
                                                       uint16_t* above, const uint16_t* up, uint16_t* row) {
  // Sixteen samples per step in 16-bit lanes (the arithmetic is modulo 2^16 anyway); blocks
  // with escapes rebuild their residuals eight at a time in 32-bit lanes first.
  const __m256i one = _mm256_set1_epi16(1);
  // Broadcast of 16-bit lane 7 within each 128-bit half.
  const __m256i lane7 = _mm256_setr_epi8(14, 15, 14, 15, 14, 15, 14, 15, 14, 15, 14, 15, 14, 15, 14, 15, 14,
                                         15, 14, 15, 14, 15, 14, 15, 14, 15, 14, 15, 14, 15, 14, 15);
  __m256i acc = _mm256_setzero_si256();
  uint64_t pos = bit_pos;
  for (uint32_t x = 0; x < width; x += 16) {
    const __m128i t8 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(tokens + x));
    // Bit 5 of a token (an escape, tokens being below 64) moved to bit 7 of its byte.
    const uint32_t escapes_here = uint32_t(_mm_movemask_epi8(_mm_slli_epi16(t8, 2)));
    __m256i z;
    if (escapes_here == 0) {
      z = _mm256_cvtepu8_epi16(t8);
    } else {
      const __m256i lo = residuals8(t8, escapes, pos);
      const __m256i hi = residuals8(_mm_srli_si128(t8, 8), escapes, pos);
      z = _mm256_permute4x64_epi64(_mm256_packus_epi32(lo, hi), 0xD8);  // z < 2^16: no saturation
    }
    __m256i r = _mm256_xor_si256(_mm256_srli_epi16(z, 1),
                                 _mm256_sub_epi16(_mm256_setzero_si256(), _mm256_and_si256(z, one)));
    if (above) {
      __m256i* a = reinterpret_cast<__m256i*>(above + x);
      r = _mm256_add_epi16(r, _mm256_loadu_si256(a));
      _mm256_storeu_si256(a, r);
    }
    r = _mm256_add_epi16(r, _mm256_slli_si256(r, 2));
    r = _mm256_add_epi16(r, _mm256_slli_si256(r, 4));
    r = _mm256_add_epi16(r, _mm256_slli_si256(r, 8));
    const __m256i low_total = _mm256_shuffle_epi8(r, lane7);
    r = _mm256_add_epi16(r, _mm256_permute2x128_si256(low_total, low_total, 0x08));  // into the high half
    const __m256i sums = _mm256_add_epi16(r, acc);
    acc = _mm256_permute4x64_epi64(_mm256_shuffle_epi8(sums, lane7), 0xFF);  // lane 15 everywhere
    const __m256i row_above = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(up + x));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(row + x), _mm256_add_epi16(row_above, sums));
  }
  bit_pos = pos;
}

#else

bool fast_coder_avx2_built() { return false; }
void encode_symbols_avx2(const uint16_t*, size_t, const PackedEncSymbol*, uint32_t*, uint16_t*&) {}
void token_row_dense_avx2(const uint16_t*, uint32_t, uint8_t*, EscapeBitWriter&) {}
void plane_residual_row_avx2(const uint16_t*, const uint16_t*, uint32_t, uint32_t, uint16_t*) {}
void unshift_samples_avx2(uint16_t*, size_t, uint32_t, uint32_t) {}
uint64_t bit_width_sum_avx2(const uint16_t*, uint32_t) { return 0; }
uint32_t context_row_avx2(const uint8_t*, uint32_t, uint8_t*) { return 1; }
void residual_row_avx2(const uint8_t*, uint32_t, const uint8_t*, uint64_t&, uint16_t*, const uint16_t*,
                       uint16_t*) {}
uint32_t decode_token_row_avx2(uint32_t*, const uint8_t*&, const uint32_t*, const uint8_t*, uint32_t,
                               uint8_t*) {
  return 0;
}

#endif

}  // namespace loam::codec
