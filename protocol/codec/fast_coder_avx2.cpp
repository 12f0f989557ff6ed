#include "protocol/codec/fast_coder_avx2.h"

#include <array>
#include <bit>
#include <cstring>

#include "protocol/codec/rans.h"
#include "protocol/codec/residual_tokens.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define LOAM_RANS_AVX2 1
#include <immintrin.h>
#endif

namespace loam::codec {

PackedEncSymbol pack_enc_symbol(uint32_t start, uint32_t freq) {
  const uint64_t reciprocal = ((uint64_t(1) << rans::kReciprocalShift) + freq - 1) / freq;
  return {freq | uint32_t((reciprocal & ((1u << 21) - 1)) << 11), start | uint32_t((reciprocal >> 21) << 10)};
}

#ifdef LOAM_RANS_AVX2

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

}  // namespace

bool fast_coder_avx2_built() { return true; }

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

__attribute__((target("avx2"))) void residual_row_avx2(const uint8_t* tokens, uint32_t width,
                                                       const uint8_t* escapes, uint64_t& bit_pos,
                                                       const uint16_t* up, uint16_t* row) {
  const __m256i direct_max = _mm256_set1_epi32(int(kDirectTokens) - 1);
  const __m256i one = _mm256_set1_epi32(1);
  const __m256i last = _mm256_set1_epi32(7);
  // Low 16 bits of each 32-bit lane, packed into the low 8 bytes of each half.
  const __m256i low_halves = _mm256_setr_epi8(0, 1, 4, 5, 8, 9, 12, 13, -1, -1, -1, -1, -1, -1, -1, -1, 0, 1,
                                              4, 5, 8, 9, 12, 13, -1, -1, -1, -1, -1, -1, -1, -1);
  __m256i acc = _mm256_setzero_si256();
  uint64_t pos = bit_pos;
  for (uint32_t x = 0; x < width; x += 8) {
    const __m256i t = _mm256_cvtepu8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(tokens + x)));
    const __m256i esc = _mm256_cmpgt_epi32(t, direct_max);
    __m256i z = t;
    if (!_mm256_testz_si256(esc, esc)) {
      // bits = 4 + (t - 32) / 2, base = (2 | (t & 1)) << bits for escapes (residual_tokens.h).
      const __m256i bits = _mm256_and_si256(
          esc, _mm256_add_epi32(_mm256_srli_epi32(_mm256_sub_epi32(t, _mm256_set1_epi32(32)), 1),
                                _mm256_set1_epi32(4)));
      const __m256i base =
          _mm256_sllv_epi32(_mm256_or_si256(_mm256_and_si256(t, one), _mm256_set1_epi32(2)), bits);
      const __m256i ends = prefix_sum8(bits);
      const __m256i offs = _mm256_add_epi32(_mm256_sub_epi32(ends, bits), _mm256_set1_epi32(int(pos & 7)));
      const __m256i raw = _mm256_i32gather_epi32(reinterpret_cast<const int*>(escapes + (pos >> 3)),
                                                 _mm256_srli_epi32(offs, 3), 1);
      const __m256i mask = _mm256_sub_epi32(_mm256_sllv_epi32(one, bits), one);
      const __m256i v = _mm256_and_si256(_mm256_srlv_epi32(raw, _mm256_and_si256(offs, last)), mask);
      z = _mm256_blendv_epi8(t, _mm256_or_si256(base, v), esc);
      pos += uint32_t(_mm256_extract_epi32(ends, 7));
    }
    const __m256i r = _mm256_xor_si256(_mm256_srli_epi32(z, 1),
                                       _mm256_sub_epi32(_mm256_setzero_si256(), _mm256_and_si256(z, one)));
    const __m256i sums = _mm256_add_epi32(prefix_sum8(r), acc);
    acc = _mm256_permutevar8x32_epi32(sums, last);
    const __m256i above = _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(up + x)));
    const __m256i packed = _mm256_permute4x64_epi64(
        _mm256_shuffle_epi8(_mm256_add_epi32(above, sums), low_halves), 0x08);  // qwords 0 and 2
    _mm_storeu_si128(reinterpret_cast<__m128i*>(row + x), _mm256_castsi256_si128(packed));
  }
  bit_pos = pos;
}

#else

bool fast_coder_avx2_built() { return false; }
void encode_symbols_avx2(const uint16_t*, size_t, const PackedEncSymbol*, uint32_t*, uint16_t*&) {}
void token_row_dense_avx2(const uint16_t*, uint32_t, uint8_t*, EscapeBitWriter&) {}
void residual_row_avx2(const uint8_t*, uint32_t, const uint8_t*, uint64_t&, const uint16_t*, uint16_t*) {}
uint32_t decode_token_row_avx2(uint32_t*, const uint8_t*&, const uint32_t*, const uint8_t*, uint32_t,
                               uint8_t*) {
  return 0;
}

#endif

}  // namespace loam::codec
