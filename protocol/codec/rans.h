// Static interleaved rANS: the entropy stage of the region codec's fast mode.
//
// rANS (range asymmetric numeral systems, J. Duda) with a frequency table fixed per payload:
// one 32-bit state per lane, kept in [kStateLow, 2^32) and renormalized 16 bits at a time;
// symbol probabilities are frequencies out of kProbScale (10 bits: on the DEMs here 12 bits
// saves under 0.1%, and 10 bits keep eight contexts' decode tables in 32 KiB, inside L1).
// 32 states are interleaved over one word stream (symbol i uses state i % kLanes), so a
// decoder has 32 independent dependency chains: the AVX2 decoder keeps four vectors of eight
// states in flight, the portable one as many scalar chains as the core can overlap. The encoder runs
// backwards over the symbols and writes words backwards; the decoder reads them forwards.
//
// The encoder divides by the frequency with an exact reciprocal: for x < f * 2^22 (what
// renormalization leaves) and f <= 1024, floor(x / f) == (x * ceil(2^42 / f)) >> 42, with the
// product below 2^64 (docs/codec.md, "rANS"; tested for every f).
//
// Safety on untrusted input: build_decode_table validates the frequencies (sum exactly
// kProbScale); a decode table maps every slot to a valid symbol, so decode_step is safe for
// any state. Callers bound the word reads (decode_step reads one word unconditionally).
#pragma once

#include <cstdint>
#include <span>

#include "protocol/byte_order.h"

namespace loam::codec::rans {

inline constexpr uint32_t kProbBits = 10;
inline constexpr uint32_t kProbScale = 1u << kProbBits;
inline constexpr uint32_t kStateLow = 1u << 16;  // states live in [kStateLow, 2^32)
inline constexpr int kLanes = 32;                // interleaved states: symbol i uses state i % 32
inline constexpr uint32_t kReciprocalShift = 42;

// Scales `counts` to frequencies summing to kProbScale with every counted symbol at least 1
// (freqs.size() == counts.size()). All-zero counts give all-zero frequencies.
void normalize_frequencies(std::span<const uint32_t> counts, std::span<uint16_t> freqs);

// What the encoder needs per symbol.
struct EncSymbol {
  uint32_t x_limit = 0;     // emit 16 bits first when the state exceeds this: (f << 22) - 1
  uint16_t start = 0;       // cumulative frequency of the symbols before this one
  uint16_t complement = 0;  // kProbScale - f
  uint64_t reciprocal = 0;  // ceil(2^42 / f)
};
static_assert(sizeof(EncSymbol) == 16);
EncSymbol make_enc_symbol(uint32_t start, uint32_t freq);  // 1 <= freq <= kProbScale

// floor(x / freq) as the encoder computes it (for tests): x < freq << 22.
inline uint32_t encoder_quotient(uint32_t x, const EncSymbol& s) {
  return uint32_t((uint64_t(x) * s.reciprocal) >> kReciprocalShift);
}

// Encodes one symbol into state x. `words` points one past the lowest word written so far;
// the step writes words[-1] whether or not it keeps it, so the buffer needs one spare word
// below the last kept one.
inline void encode_step(uint32_t& x, uint16_t*& words, const EncSymbol& s) {
  // Written with a mask and a shift by 0 or 16 rather than a condition: GCC turns the
  // conditional form into a branch that mispredicts on every other word.
  const uint32_t emit = uint32_t(x > s.x_limit);
  words[-1] = uint16_t(x);
  words -= emit;
  x >>= emit << 4;
  const uint32_t q = encoder_quotient(x, s);
  x = x + s.start + q * uint32_t(s.complement);
}

// Decode table entry per slot: symbol (bits 0-7), slot - start (bits 8-17), frequency
// (bits 18-28).
inline constexpr uint32_t pack_slot(uint32_t symbol, uint32_t freq, uint32_t bias) {
  return symbol | (bias << 8) | (freq << 18);
}
// Fills table[0, kProbScale) from `freqs` (symbol s owns freqs[s] consecutive slots). False
// when the frequencies do not sum to exactly kProbScale.
bool build_decode_table(std::span<const uint16_t> freqs, std::span<uint32_t> table);
// The table of a context that never occurs: every slot decodes symbol 0 with probability 1.
void fill_unused_decode_table(std::span<uint32_t> table);

// Decodes one symbol from state x with `table` (kProbScale entries); returns it. Reads the
// word at `words` always and consumes it only when the state needs it.
inline uint32_t decode_step(uint32_t& x, const uint8_t*& words, const uint32_t* table) {
  const uint32_t e = table[x & (kProbScale - 1)];
  const uint32_t y = (e >> 18) * (x >> kProbBits) + ((e >> 8) & (kProbScale - 1));
  const uint32_t w = load_le<uint16_t>(words);
  // Masks, not a condition (see encode_step).
  const uint32_t refill = uint32_t(y < kStateLow);
  const uint32_t mask = 0u - refill;
  x = (y & ~mask) | (((y << 16) | w) & mask);
  words += 2 * refill;
  return e & 0xFFu;
}

}  // namespace loam::codec::rans
