#include "protocol/codec/fast_coder.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>
#include <string>
#include <type_traits>

#include "protocol/byte_order.h"
#include "protocol/codec/escape_bits.h"
#include "protocol/codec/fast_coder_avx2.h"
#include "protocol/codec/rans.h"

// The row passes (prediction, contexts, the running-sum inverse) have no loop-carried
// dependency worth the name; GCC vectorizes them only above -O2's very-cheap cost model.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("O3")
#endif

namespace loam::codec {
namespace {

constexpr uint32_t kSymbolsPerContext = 64;  // sym index = context * 64 + token
constexpr size_t kStatesBytes = 4 * rans::kLanes;

template <typename U>
U zigzag(U r) {
  constexpr int kBits = int(sizeof(U)) * 8;
  using S = std::make_signed_t<U>;
  return U(U(r << 1) ^ U(S(r) >> (kBits - 1)));
}
template <typename U>
U unzigzag(U z) {
  return U(U(z >> 1) ^ U(-U(z & 1u)));
}

template <typename T>
T* grown(std::vector<T>& v, size_t n) {
  if (v.size() < n) v.resize(n);
  return v.data();
}

// Per-thread scratch: after the first region of a size, coding allocates nothing but the
// bytes it appends.
struct Scratch {
  std::vector<uint16_t> residuals;                              // one row, as U
  std::vector<uint16_t> above;                                  // predictor 1: plane residuals above, as U
  std::vector<uint8_t> tokens[2];                               // this row and the row above
  std::vector<uint8_t> contexts;                                // one row
  std::vector<uint16_t> symbols;                                // encoder: context * 64 + token per sample
  std::vector<uint16_t> words;                                  // encoder: the rANS words, written backwards
  std::vector<uint8_t> extras;                                  // encoder: the escape bits
  std::vector<uint16_t> zero_row;                               // the row above the first row (never written)
  std::vector<uint8_t> word_tail, escape_tail;                  // decoder: padded ends of the sections
  std::array<uint32_t, kContexts * rans::kProbScale> tables{};  // decoder
};
Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

// --- Row passes shared by encoder and decoder ---------------------------------------------

// Zigzag plane residuals of one row (samples shifted right by `shift`); `up` is the row
// above (zeros for the first row).
template <typename U>
[[gnu::always_inline]] inline void plane_residual_row(const U* __restrict cur, const U* __restrict up,
                                                      uint32_t width, uint32_t shift, U* __restrict z) {
  z[0] = zigzag(U(U(cur[0] >> shift) - U(up[0] >> shift)));
  for (uint32_t x = 1; x < width; ++x) {
    const U d = U(U(cur[x] >> shift) - U(up[x] >> shift));
    const U dw = U(U(cur[x - 1] >> shift) - U(up[x - 1] >> shift));
    z[x] = zigzag(U(d - dw));
  }
}

// Predictor 1: the zigzag plane residuals z of a row become those of the plane residual
// minus the plane residual above (`above`, signed, updated to this row's).
template <typename U>
[[gnu::always_inline]] inline void subtract_residuals_above(U* __restrict z, U* __restrict above,
                                                            uint32_t width) {
  for (uint32_t x = 0; x < width; ++x) {
    const U r = unzigzag(z[x]);
    z[x] = zigzag(U(r - above[x]));
    above[x] = r;
  }
}

// Sum over a row of zigzag residuals of their bit widths: the encoder's estimate of what
// a predictor costs.
template <bool kAvx2, typename U>
[[gnu::always_inline]] inline uint64_t bit_width_sum(const U* z, uint32_t width) {
  if constexpr (kAvx2 && sizeof(U) == 2) {
    return bit_width_sum_avx2(z, width);
  } else {
    uint64_t sum = 0;
    for (uint32_t x = 0; x < width; ++x) sum += uint64_t(std::bit_width(uint32_t(z[x])));
    return sum;
  }
}

// Contexts of one row from the tokens of the row above.
template <bool kAvx2>
[[gnu::always_inline]] inline void context_row(const uint8_t* __restrict up, uint32_t width, bool first_row,
                                               uint8_t* __restrict ctx) {
  if (first_row) {
    std::memset(ctx, kFirstRowContext, width);
    return;
  }
  if (width == 1) {
    ctx[0] = context_of(uint8_t(4 * up[0]));
    return;
  }
  ctx[0] = context_of(uint8_t(3 * up[0] + up[1]));
  uint32_t x = 1;
  if constexpr (kAvx2) x = context_row_avx2(up, width, ctx);
  for (; x + 1 < width; ++x) ctx[x] = context_of(uint8_t(2 * up[x] + up[x - 1] + up[x + 1]));
  ctx[width - 1] = context_of(uint8_t(3 * up[width - 1] + up[width - 2]));
}

// Calls f(x) for each x in increasing order whose token is an escape (t >= 32, i.e. bit 5
// of a token below 64), eight tokens per test: escapes are a minority on most rows.
template <typename F>
[[gnu::always_inline]] inline void for_each_escape(const uint8_t* t, uint32_t width, F&& f) {
  uint32_t x = 0;
  if constexpr (std::endian::native == std::endian::little) {
    for (; x + 8 <= width; x += 8) {
      uint64_t m;
      std::memcpy(&m, t + x, 8);
      for (m &= 0x2020202020202020ull; m != 0; m &= m - 1) f(x + uint32_t(std::countr_zero(m)) / 8);
    }
  }
  for (; x < width; ++x)
    if (t[x] & kDirectTokens) f(x);
}

// --- Encoder ---------------------------------------------------------------------------

// Tokens of one row of residuals z, their escape bits appended to `extras`.
template <bool kAvx2, typename U>
[[gnu::always_inline]] inline void token_row(const U* __restrict z, uint32_t width, uint8_t* __restrict t,
                                             EscapeBitWriter& extras) {
  // Direct tokens in one vectorized pass (escapes marked 32), then the escapes: one by one
  // where they are few, or every sample without a branch where they are many.
  uint32_t escapes = 0;
  for (uint32_t x = 0; x < width; ++x) {
    t[x] = uint8_t(std::min<uint32_t>(z[x], kDirectTokens));
    escapes += z[x] >= kDirectTokens ? 1 : 0;
  }
  if (escapes == 0) return;
  if (escapes * 8 < width) {
    for_each_escape(t, width, [&](uint32_t x) {
      const uint32_t v = z[x];
      const uint32_t k = token_of(v);
      const uint32_t bits = token_extra_bits(k);
      t[x] = uint8_t(k);
      extras.put(v & ((1u << bits) - 1), bits);
    });
    return;
  }
  if constexpr (kAvx2 && sizeof(U) == 2) {
    if (width % 8 == 0) {
      token_row_dense_avx2(z, width, t, extras);
      return;
    }
  }
  for (uint32_t x = 0; x < width; ++x) {
    const uint32_t v = z[x];
    const uint32_t b = uint32_t(std::bit_width(v | 2u));  // >= 2; the true width where it matters
    const uint32_t esc = 0u - uint32_t(v >= kDirectTokens);
    const uint32_t k = ((kDirectTokens + 2 * (b - 6) + ((v >> (b - 2)) & 1u)) & esc) | (v & ~esc);
    const uint32_t bits = (b - 2) & esc;
    t[x] = uint8_t(k);
    extras.put(v & ((1u << bits) - 1), bits);
  }
}

void put_tables(std::vector<uint8_t>& out, const std::array<std::array<uint16_t, kMaxTokens>, kContexts>& f,
                uint32_t tokens) {
  for (int c = 0; c < kContexts; ++c) {
    uint32_t count = tokens;
    while (count > 0 && f[size_t(c)][count - 1] == 0) --count;
    out.push_back(uint8_t(count));
    for (uint32_t t = 0; t < count; ++t) {
      const uint32_t v = f[size_t(c)][t];
      if (v < 128) {
        out.push_back(uint8_t(v));
      } else {
        out.push_back(uint8_t(0x80u | (v & 0x7Fu)));
        out.push_back(uint8_t(v >> 7));
      }
    }
  }
}

// rANS over the samples' symbols, backwards; sample i uses state i % kLanes.
void encode_symbols(const uint16_t* sym, size_t n, const rans::EncSymbol* enc, const PackedEncSymbol* packed,
                    uint32_t* st, uint16_t*& words, Isa isa) {
  uint16_t* w = words;
  size_t i = n;
  for (; i % rans::kLanes != 0; --i) rans::encode_step(st[(i - 1) % rans::kLanes], w, enc[sym[i - 1]]);
  if (isa == Isa::kAvx2 && fast_coder_avx2_built()) {
    encode_symbols_avx2(sym, i, packed, st, w);
  } else {
    // Whole groups of kLanes with the lane fixed per statement (no index arithmetic).
    for (; i > 0; i -= rans::kLanes) {
      const uint16_t* g = sym + i - rans::kLanes;
#pragma GCC unroll 32
      for (int j = rans::kLanes - 1; j >= 0; --j) rans::encode_step(st[j], w, enc[g[j]]);
    }
  }
  words = w;
}

// Four histograms (sample i counts in i % 4) so that runs of one symbol do not serialize
// on one counter's store-to-load latency.
using Histograms = std::array<std::array<uint32_t, kContexts * kSymbolsPerContext>, 4>;

// The residual row of `predictor` (docs/codec.md, "fast"); `above` holds the plane
// residuals of the row above for predictor 1.
template <bool kAvx2, typename U>
[[gnu::always_inline]] inline void residual_row_of(const U* s, uint32_t width, uint32_t y, uint32_t shift,
                                                   uint32_t predictor, const U* zeros, U* above, U* z) {
  const U* cur = s + size_t(y) * width;
  if constexpr (kAvx2 && sizeof(U) == 2) {
    plane_residual_row_avx2(cur, y == 0 ? zeros : cur - width, width, shift, z);
  } else {
    plane_residual_row(cur, y == 0 ? zeros : cur - width, width, shift, z);
  }
  if (predictor == 1) subtract_residuals_above(z, above, width);
}

// Which predictor to use: the one whose residuals have the smaller sum of bit widths (on
// the DEMs here within 0.4% of trying both; predictor 1 wins on DEMs upsampled from a
// coarser grid, whose plane residuals repeat down each cell).
template <bool kAvx2, typename U>
[[gnu::always_inline]] inline uint32_t choose_predictor(const U* s, uint32_t width, uint32_t height,
                                                        uint32_t shift, Scratch& sc) {
  U* z = reinterpret_cast<U*>(sc.residuals.data());
  U* above = reinterpret_cast<U*>(sc.above.data());
  const U* zeros = reinterpret_cast<const U*>(sc.zero_row.data());
  std::fill(above, above + width, U(0));
  uint64_t plane = 0, minus_above = 0;
  for (uint32_t y = 0; y < height; ++y) {
    residual_row_of<kAvx2>(s, width, y, shift, 0, zeros, above, z);
    plane += bit_width_sum<kAvx2>(z, width);
    subtract_residuals_above(z, above, width);
    minus_above += bit_width_sum<kAvx2>(z, width);
  }
  return minus_above < plane ? 1 : 0;
}

// Pass 1 over the samples: residuals, tokens (escape bits to `extras`), contexts, the
// symbol (context * 64 + token) of every sample and its histograms. One source compiled
// for the baseline and for AVX2 (the integers are the same).
template <bool kAvx2, typename U>
[[gnu::always_inline]] inline void analyse_kernel(const U* s, uint32_t width, uint32_t height, uint32_t shift,
                                                  uint32_t predictor, Scratch& sc, uint16_t* sym,
                                                  EscapeBitWriter& extras, Histograms& hist) {
  U* z = reinterpret_cast<U*>(sc.residuals.data());
  U* above = reinterpret_cast<U*>(sc.above.data());
  const U* zeros = reinterpret_cast<const U*>(sc.zero_row.data());
  uint8_t* tok[2] = {sc.tokens[0].data(), sc.tokens[1].data()};
  uint8_t* ctx = sc.contexts.data();
  std::fill(above, above + width, U(0));
  for (uint32_t y = 0; y < height; ++y) {
    residual_row_of<kAvx2>(s, width, y, shift, predictor, zeros, above, z);
    uint8_t* t = tok[y & 1];
    token_row<kAvx2>(z, width, t, extras);
    context_row<kAvx2>(tok[(y + 1) & 1], width, y == 0, ctx);
    uint16_t* row_sym = sym + size_t(y) * width;
    for (uint32_t x = 0; x < width; ++x) row_sym[x] = uint16_t(ctx[x] * kSymbolsPerContext + t[x]);
    const size_t i0 = size_t(y) * width;
    uint32_t x = 0;
    if (i0 % 4 == 0) {
      for (; x + 4 <= width; x += 4) {
        ++hist[0][row_sym[x]];
        ++hist[1][row_sym[x + 1]];
        ++hist[2][row_sym[x + 2]];
        ++hist[3][row_sym[x + 3]];
      }
    }
    for (; x < width; ++x) ++hist[(i0 + x) & 3][row_sym[x]];
  }
}
// Chooses the predictor and runs pass 1; returns the predictor.
template <typename U>
uint32_t analyse_portable(const U* s, uint32_t width, uint32_t height, uint32_t shift, Scratch& sc,
                          uint16_t* sym, EscapeBitWriter& extras, Histograms& hist) {
  const uint32_t predictor = choose_predictor<false>(s, width, height, shift, sc);
  analyse_kernel<false>(s, width, height, shift, predictor, sc, sym, extras, hist);
  return predictor;
}
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
template <typename U>
__attribute__((target("avx2"))) uint32_t analyse_avx2(const U* s, uint32_t width, uint32_t height,
                                                      uint32_t shift, Scratch& sc, uint16_t* sym,
                                                      EscapeBitWriter& extras, Histograms& hist) {
  const uint32_t predictor = choose_predictor<true>(s, width, height, shift, sc);
  analyse_kernel<true>(s, width, height, shift, predictor, sc, sym, extras, hist);
  return predictor;
}
#else
template <typename U>
uint32_t analyse_avx2(const U* s, uint32_t width, uint32_t height, uint32_t shift, Scratch& sc, uint16_t* sym,
                      EscapeBitWriter& extras, Histograms& hist) {
  return analyse_portable(s, width, height, shift, sc, sym, extras, hist);
}
#endif

template <typename U>
void encode_body(const U* s, uint32_t width, uint32_t height, std::vector<uint8_t>& out, Isa isa) {
  constexpr int kBits = int(sizeof(U)) * 8;
  constexpr uint32_t kTokens = token_count(kBits);
  const size_t n = size_t(width) * height;
  Scratch& sc = scratch();

  // Preamble: samples sharing their low bits are coded shifted (see docs/codec.md).
  uint32_t shift = 0, low = 0;
  if constexpr (kBits == 16) {
    uint32_t diff = 0;
    for (size_t i = 0; i < n; ++i) diff |= uint32_t(s[i] ^ s[0]);
    shift = diff == 0 ? 0 : uint32_t(std::countr_zero(diff));
    low = s[0] & ((1u << shift) - 1);
  }
  out.push_back(uint8_t(shift));
  if (shift > 0) append_le<uint16_t>(out, uint16_t(low));

  // Predictor choice and pass 1.
  grown(sc.residuals, width);
  grown(sc.above, width);
  grown(sc.zero_row, width);
  grown(sc.tokens[0], width);
  grown(sc.tokens[1], width);
  grown(sc.contexts, width);
  uint16_t* sym = grown(sc.symbols, n);
  EscapeBitWriter extras(grown(sc.extras, n * 14 / 8 + 16));
  Histograms hist{};
  const uint32_t predictor = isa == Isa::kAvx2 && fast_coder_avx2_built()
                                 ? analyse_avx2(s, width, height, shift, sc, sym, extras, hist)
                                 : analyse_portable(s, width, height, shift, sc, sym, extras, hist);
  out.push_back(uint8_t(predictor));
  const size_t extras_bytes = extras.finish();

  // Tables.
  std::array<std::array<uint16_t, kMaxTokens>, kContexts> freqs{};
  std::array<rans::EncSymbol, kContexts * kSymbolsPerContext> enc{};
  std::array<PackedEncSymbol, kContexts * kSymbolsPerContext> packed{};
  for (int c = 0; c < kContexts; ++c) {
    std::array<uint32_t, kMaxTokens> counts{};
    for (uint32_t t = 0; t < kTokens; ++t) {
      const size_t k = size_t(c) * kSymbolsPerContext + t;
      counts[t] = hist[0][k] + hist[1][k] + hist[2][k] + hist[3][k];
    }
    rans::normalize_frequencies(std::span(counts).first(kTokens), std::span(freqs[size_t(c)]).first(kTokens));
    uint32_t start = 0;
    for (uint32_t t = 0; t < kTokens; ++t) {
      const uint32_t f = freqs[size_t(c)][t];
      if (f > 0) {
        enc[size_t(c) * kSymbolsPerContext + t] = rans::make_enc_symbol(start, f);
        packed[size_t(c) * kSymbolsPerContext + t] = pack_enc_symbol(start, f);
      }
      start += f;
    }
  }
  put_tables(out, freqs, kTokens);

  // Pass 2: rANS, backwards. The words buffer has slack below for the AVX2 kernel.
  constexpr size_t kSlack = 16;
  uint16_t* words_end = grown(sc.words, n + kSlack) + n + kSlack;
  uint16_t* w = words_end;
  uint32_t st[rans::kLanes];
  for (uint32_t& x : st) x = rans::kStateLow;
  encode_symbols(sym, n, enc.data(), packed.data(), st, w, isa);
  const size_t nwords = size_t(words_end - w);

  // Sections: rANS length, states, words, escape bits.
  const size_t rans_bytes = kStatesBytes + 2 * nwords;
  const size_t at = out.size();
  out.resize(at + 4 + rans_bytes + extras_bytes);
  uint8_t* p = out.data() + at;
  store_le<uint32_t>(p, uint32_t(rans_bytes));
  p += 4;
  for (uint32_t x : st) {
    store_le<uint32_t>(p, x);
    p += 4;
  }
  if constexpr (std::endian::native == std::endian::little) {
    if (nwords > 0) std::memcpy(p, w, 2 * nwords);
  } else {
    for (size_t k = 0; k < nwords; ++k) {
      p[2 * k] = uint8_t(w[k]);
      p[2 * k + 1] = uint8_t(w[k] >> 8);
    }
  }
  p += 2 * nwords;
  if (extras_bytes > 0) std::memcpy(p, sc.extras.data(), extras_bytes);
}

// --- Decoder ---------------------------------------------------------------------------

// What an escape token contributes before its raw bits: z = base + raw, raw having `bits`
// bits (0 for direct tokens, whose base is the token itself). Indexed by any token < 64.
struct TokenLayout {
  uint16_t base[64];
  uint8_t bits[64];
};
constexpr TokenLayout make_token_layout() {
  TokenLayout l{};
  for (uint32_t t = 0; t < 64; ++t) {
    l.bits[t] = uint8_t(token_extra_bits(t));
    l.base[t] = uint16_t(t < kDirectTokens ? t : residual_of(t, 0));
  }
  return l;
}
constexpr TokenLayout kTokenLayout = make_token_layout();

// The rANS decoder's position: its states and the word stream. Rows decode without bounds
// checks (at most one word per sample), so at least 2 * width bytes must be readable at p:
// near the end of the stream the rest is copied into a zero-padded buffer, and a stream
// that ends early shows as p past `end`.
class RansWords {
 public:
  // `tail` is storage for the padded copy of the stream's end (reused across calls).
  RansWords(const FastBody& fb, uint32_t width, std::vector<uint8_t>& tail) : width_(width), tail_(tail) {
    std::memcpy(states, fb.states.data(), sizeof states);
    p = fb.words.data();
    end_ = fb.words.data() + fb.words.size();
    readable_ = end_;
  }
  // Makes the next row safe to decode unchecked; false once the stream has overrun.
  bool prepare_row() {
    if (p > end_) return false;
    if (size_t(readable_ - p) < 2 * size_t(width_)) {
      const size_t left = size_t(end_ - p);
      tail_.assign(left + 2 * size_t(width_) + 32, 0);
      if (left > 0) std::memcpy(tail_.data(), p, left);
      p = tail_.data();
      end_ = p + left;
      readable_ = tail_.data() + tail_.size();
    }
    return true;
  }
  bool overran() const { return p > end_; }
  size_t left() const { return p <= end_ ? size_t(end_ - p) : 0; }

  uint32_t states[rans::kLanes];
  const uint8_t* p;

 private:
  uint32_t width_;
  const uint8_t* end_;
  const uint8_t* readable_;
  std::vector<uint8_t>& tail_;
};

// Decodes one row of tokens; returns the OR of them (bit 5 set when any is an escape).
uint32_t decode_token_row(RansWords& rw, const uint32_t* tables, const uint8_t* __restrict ctx, size_t i0,
                          uint32_t width, uint8_t* __restrict t, Isa isa) {
  if (width % rans::kLanes == 0 && isa == Isa::kAvx2 && fast_coder_avx2_built()) {
    return decode_token_row_avx2(rw.states, rw.p, tables, ctx, width, t);
  }
  uint32_t any = 0;
  const uint8_t* p = rw.p;
  for (uint32_t x = 0; x < width; ++x) {
    const uint32_t k = rans::decode_step(rw.states[(i0 + x) % rans::kLanes], p,
                                         tables + (size_t(ctx[x]) << rans::kProbBits));
    t[x] = uint8_t(k);
    any |= k;
  }
  rw.p = p;
  return any;
}

// Rebuilds one row of samples from its tokens: escape bits, zigzag, (predictor 1: the
// plane residuals above added, `above` updated), running sum, row above.
template <typename U>
void residual_row(const uint8_t* __restrict t, uint32_t width, uint32_t any, EscapeBitReader& extras,
                  U* __restrict above, const U* __restrict up, U* __restrict row, Isa isa) {
  if constexpr (sizeof(U) == 2) {
    if (width % 16 == 0 && isa == Isa::kAvx2 && fast_coder_avx2_built()) {
      residual_row_avx2(t, width, extras.data(), extras.position(), above, up, row);
      return;
    }
  }
  U acc = 0;
  for (uint32_t x = 0; x < width; ++x) {
    const uint32_t k = t[x];
    // Every sample takes its (possibly zero) raw bits: no branch per sample.
    const U z =
        (any & kDirectTokens) == 0 ? U(k) : U(kTokenLayout.base[k] | extras.get(kTokenLayout.bits[k]));
    U r = unzigzag(z);
    if (above) {
      r = U(r + above[x]);
      above[x] = r;
    }
    acc = U(acc + r);
    row[x] = U(up[x] + acc);
  }
}

template <typename U>
Status decode_body(const FastBody& fb, uint32_t width, uint32_t height, U* out, Isa isa) {
  Scratch& sc = scratch();
  for (int c = 0; c < kContexts; ++c) {
    const std::span<uint32_t> table(sc.tables.data() + size_t(c) * rans::kProbScale, rans::kProbScale);
    const auto& f = fb.freqs[size_t(c)];
    if (std::all_of(f.begin(), f.end(), [](uint16_t v) { return v == 0; })) {
      rans::fill_unused_decode_table(table);
    } else {
      (void)rans::build_decode_table(f, table);  // parse_fast_body checked the sum
    }
  }
  uint8_t* tok[2] = {grown(sc.tokens[0], width), grown(sc.tokens[1], width)};
  uint8_t* ctx = grown(sc.contexts, width);
  const U* zeros = reinterpret_cast<const U*>(grown(sc.zero_row, width));
  U* above = nullptr;
  if (fb.predictor == 1) {
    above = reinterpret_cast<U*>(grown(sc.above, width));
    std::fill(above, above + width, U(0));
  }

  RansWords rw(fb, width, sc.word_tail);
  EscapeBitReader extras(fb.extras, width, sc.escape_tail);
  for (uint32_t y = 0; y < height; ++y) {
    if (!rw.prepare_row() || !extras.prepare_row()) break;
    const size_t i0 = size_t(y) * width;
    uint8_t* t = tok[y & 1];
    if (isa == Isa::kAvx2 && fast_coder_avx2_built()) {
      context_row<true>(tok[(y + 1) & 1], width, y == 0, ctx);
    } else {
      context_row<false>(tok[(y + 1) & 1], width, y == 0, ctx);
    }
    const uint32_t any = decode_token_row(rw, sc.tables.data(), ctx, i0, width, t, isa);
    U* row = out + i0;
    residual_row(t, width, any, extras, above, y == 0 ? zeros : row - width, row, isa);
  }
  if (rw.overran())
    return make_error(ErrorCode::kTruncated, "region.fast.rans", "word stream ended before the last sample");
  if (rw.left() != 0) {
    return make_error(ErrorCode::kCorrupt, "region.fast.rans",
                      std::to_string(rw.left()) + " bytes after the last sample");
  }
  for (uint32_t x : rw.states)
    if (x != rans::kStateLow)
      return make_error(ErrorCode::kCorrupt, "region.fast.rans", "final state mismatch");
  if (extras.overran())
    return make_error(ErrorCode::kTruncated, "region.fast.extras", "escape bits ended early");
  if (!extras.exhausted())
    return make_error(ErrorCode::kCorrupt, "region.fast.extras", "escape bits left over");
  if (fb.shift > 0) {
    const size_t n = size_t(width) * height;
    if constexpr (sizeof(U) == 2) {
      if (isa == Isa::kAvx2 && fast_coder_avx2_built()) {
        unshift_samples_avx2(out, n, fb.shift, fb.low);
        return {};
      }
    }
    for (size_t i = 0; i < n; ++i) out[i] = U((uint32_t(out[i]) << fb.shift) | fb.low);
  }
  return {};
}

}  // namespace

void encode_fast_body(std::span<const uint16_t> samples, uint32_t width, uint32_t height,
                      std::vector<uint8_t>& out, Isa isa) {
  encode_body(samples.data(), width, height, out, isa);
}
void encode_fast_body(std::span<const int8_t> samples, uint32_t width, uint32_t height,
                      std::vector<uint8_t>& out, Isa isa) {
  encode_body(reinterpret_cast<const uint8_t*>(samples.data()), width, height, out, isa);
}

Result<FastBody> parse_fast_body(std::span<const uint8_t> body, int bits) {
  const uint32_t tokens = token_count(bits);
  FastBody fb;
  size_t at = 0;
  auto need = [&](size_t k) { return body.size() - at >= k; };
  if (!need(1)) return make_error(ErrorCode::kTruncated, "region.fast", "body too short");
  fb.shift = body[at++];
  if (fb.shift > (bits == 16 ? 15u : 0u))
    return make_error(ErrorCode::kCorrupt, "region.fast", "shift out of range");
  if (fb.shift > 0) {
    if (!need(2)) return make_error(ErrorCode::kTruncated, "region.fast", "body too short for the low bits");
    fb.low = load_le<uint16_t>(body.data() + at);
    at += 2;
    if (fb.low >= (1u << fb.shift))
      return make_error(ErrorCode::kCorrupt, "region.fast", "low bits out of range");
  }
  if (!need(1)) return make_error(ErrorCode::kTruncated, "region.fast", "body too short for the predictor");
  fb.predictor = body[at++];
  if (fb.predictor > 1) return make_error(ErrorCode::kCorrupt, "region.fast", "unknown predictor");
  for (int c = 0; c < kContexts; ++c) {
    if (!need(1))
      return make_error(ErrorCode::kTruncated, "region.fast.tables", "body ends inside the tables");
    const uint32_t count = body[at++];
    if (count > tokens)
      return make_error(ErrorCode::kCorrupt, "region.fast.tables", "more tokens than the sample type has");
    uint32_t sum = 0;
    for (uint32_t t = 0; t < count; ++t) {
      if (!need(1))
        return make_error(ErrorCode::kTruncated, "region.fast.tables", "body ends inside the tables");
      uint32_t v = body[at++];
      if (v & 0x80u) {
        if (!need(1))
          return make_error(ErrorCode::kTruncated, "region.fast.tables", "body ends inside the tables");
        v = (v & 0x7Fu) | (uint32_t(body[at++]) << 7);
        if (v < 128)
          return make_error(ErrorCode::kCorrupt, "region.fast.tables", "frequency not in its shortest form");
      }
      if (v > rans::kProbScale)
        return make_error(ErrorCode::kCorrupt, "region.fast.tables", "frequency above 1024");
      fb.freqs[size_t(c)][t] = uint16_t(v);
      sum += v;
    }
    if (count > 0 && (sum != rans::kProbScale || fb.freqs[size_t(c)][count - 1] == 0)) {
      return make_error(ErrorCode::kCorrupt, "region.fast.tables", "frequencies do not sum to 1024");
    }
  }
  if (!need(4))
    return make_error(ErrorCode::kTruncated, "region.fast.rans", "body ends before the rANS length");
  const uint32_t rans_bytes = load_le<uint32_t>(body.data() + at);
  at += 4;
  if (rans_bytes < kStatesBytes || rans_bytes % 2 != 0) {
    return make_error(ErrorCode::kCorrupt, "region.fast.rans", "rANS length is not 32 + 2 * words");
  }
  if (!need(rans_bytes))
    return make_error(ErrorCode::kTruncated, "region.fast.rans", "body shorter than the rANS length");
  for (int k = 0; k < rans::kLanes; ++k) {
    fb.states[size_t(k)] = load_le<uint32_t>(body.data() + at + 4 * size_t(k));
    if (fb.states[size_t(k)] < rans::kStateLow) {
      return make_error(ErrorCode::kCorrupt, "region.fast.rans", "initial state below 2^16");
    }
  }
  fb.words = body.subspan(at + kStatesBytes, rans_bytes - kStatesBytes);
  fb.extras = body.subspan(at + rans_bytes);
  return fb;
}

Status decode_fast_body(const FastBody& body, uint32_t width, uint32_t height, std::span<uint16_t> out,
                        Isa isa) {
  return decode_body(body, width, height, out.data(), isa);
}
Status decode_fast_body(const FastBody& body, uint32_t width, uint32_t height, std::span<int8_t> out,
                        Isa isa) {
  return decode_body(body, width, height, reinterpret_cast<uint8_t*>(out.data()), isa);
}

}  // namespace loam::codec
