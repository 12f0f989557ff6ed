// Region codec, fast mode (format version 3): the rANS arithmetic, the residual tokens, the
// AVX2 kernels against the portable loops, the documented body layout, and the rejection of
// every malformed field of the body.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "protocol/codec/fast_coder.h"
#include "protocol/codec/fast_coder_avx2.h"
#include "protocol/codec/rans.h"
#include "protocol/codec/region_codec.h"
#include "protocol/codec/residual_tokens.h"
#include "protocol/tile_hash.h"

namespace loam {
namespace {

using codec::Isa;

bool have_avx2() {
  const bool yes = codec::detected_isa() == Isa::kAvx2 && codec::fast_coder_avx2_built();
  if (!yes) std::printf("NOTE: no AVX2 here; the portable path is compared with itself\n");
  return yes;
}

// --- rANS --------------------------------------------------------------------------------

// The encoder divides by the frequency with a reciprocal (rans.h); an off-by-one anywhere
// in [0, f * 2^22) would corrupt streams only for rare states, so every frequency is checked
// at every multiple of f that matters and its neighbours, plus random states.
TEST(CodecRans, ReciprocalQuotientIsExactForEveryFrequencyAndState) {
  std::mt19937 rng(21);
  for (uint32_t f = 1; f <= codec::rans::kProbScale; ++f) {
    const codec::rans::EncSymbol s = codec::rans::make_enc_symbol(0, f);
    const uint64_t limit = uint64_t(f) << 22;  // states below this reach the division
    auto check = [&](uint64_t x) {
      if (x >= limit) return;
      ASSERT_EQ(codec::rans::encoder_quotient(uint32_t(x), s), uint32_t(x / f)) << "f " << f << " x " << x;
    };
    for (uint64_t q : {uint64_t(0), uint64_t(1), uint64_t(1) << 21, (uint64_t(1) << 22) - 1}) {
      check(q * f);
      if (q > 0) check(q * f - 1);
      check(q * f + f - 1);
    }
    for (int i = 0; i < 64; ++i) check(uint64_t(rng()) % limit);
    check(limit - 1);
  }
}

TEST(CodecRans, NormalizedFrequenciesSumToTheScaleAndKeepEverySymbolSeen) {
  std::mt19937 rng(4);
  for (int trial = 0; trial < 500; ++trial) {
    std::vector<uint32_t> counts(size_t(1 + rng() % 54));
    for (uint32_t& c : counts)
      c = uint32_t(rng() % 4 == 0 ? 0 : (trial % 3 == 0 ? rng() % 3 : rng() % 100000));
    std::vector<uint16_t> f(counts.size());
    codec::rans::normalize_frequencies(counts, f);
    uint32_t sum = 0;
    bool any = false;
    for (size_t i = 0; i < f.size(); ++i) {
      sum += f[i];
      any |= counts[i] > 0;
      EXPECT_EQ(counts[i] > 0, f[i] > 0) << "symbol " << i;
    }
    EXPECT_EQ(sum, any ? codec::rans::kProbScale : 0u);
  }
}

TEST(CodecRans, DecodeTableRejectsFrequenciesThatDoNotSumToTheScale) {
  std::vector<uint32_t> table(codec::rans::kProbScale);
  std::vector<uint16_t> f = {512, 511};
  EXPECT_FALSE(codec::rans::build_decode_table(f, table));
  f = {512, 512};
  EXPECT_TRUE(codec::rans::build_decode_table(f, table));
}

// --- Tokens ----------------------------------------------------------------------------

TEST(CodecTokens, EveryResidualIsItsTokenPlusItsRawBits) {
  for (uint32_t z = 0; z < 65536; ++z) {
    const uint32_t t = codec::token_of(z);
    ASSERT_LT(t, codec::token_count(16));
    if (z < 256) {
      ASSERT_LT(t, codec::token_count(8));
    }
    const uint32_t bits = codec::token_extra_bits(t);
    const uint32_t raw = z & ((1u << bits) - 1);
    ASSERT_EQ(t < codec::kDirectTokens ? t : codec::residual_of(t, raw), z) << z;
  }
}

// --- AVX2 against portable -------------------------------------------------------------

// A rough coarse grid bilinearly upsampled by 8 and rounded, like a DEM imported at a finer
// spacing than its source: the plane residuals repeat down each cell.
std::vector<uint16_t> upsampled(uint32_t w, uint32_t h, std::mt19937& rng) {
  const uint32_t cw = w / 8 + 2, ch = h / 8 + 2;
  std::vector<double> coarse(size_t(cw) * ch);
  for (double& c : coarse) c = 20000 + double(rng() % 3000);
  std::vector<uint16_t> s(size_t(w) * h);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      const uint32_t cx = x / 8, cy = y / 8;
      const double fx = (x % 8) / 8.0, fy = (y % 8) / 8.0;
      const double a = coarse[cy * cw + cx], b = coarse[cy * cw + cx + 1], c = coarse[(cy + 1) * cw + cx],
                   d = coarse[(cy + 1) * cw + cx + 1];
      s[size_t(y) * w + x] =
          uint16_t(std::lround((a * (1 - fx) + b * fx) * (1 - fy) + (c * (1 - fx) + d * fx) * fy));
    }
  return s;
}

std::vector<std::vector<uint16_t>> varied_inputs(uint32_t w, uint32_t h, std::mt19937& rng) {
  const size_t n = size_t(w) * h;
  std::vector<std::vector<uint16_t>> in(7, std::vector<uint16_t>(n));
  for (size_t i = 0; i < n; ++i) {
    const double x = double(i % w), y = double(i / w);
    in[0][i] = uint16_t(rng());                                        // noise: escapes everywhere
    in[1][i] = uint16_t(30000 + 40 * x + 25 * y + double(rng() % 7));  // smooth: few escapes
    in[2][i] =
        uint16_t(30000 + 200 * std::sin(x / 7) * std::cos(y / 5) + double(rng() % 90));  // some of each
    in[3][i] = uint16_t((i % 5 == 0) ? rng() : 1000);                                    // sparse escapes
    in[4][i] = uint16_t(8 * (2000 + (i * 2654435761u >> 26)) + 3);                       // shift 3
    in[5][i] = (i / w + i % w) % 2 ? 65535 : 0;  // alternating extremes
  }
  return in;
}

TEST(CodecFast, Avx2AndPortableEncodersWriteIdenticalBodies) {
  have_avx2();
  std::mt19937 rng(12);
  const std::pair<uint32_t, uint32_t> shapes[] = {{1, 1},  {3, 2},   {8, 8},   {31, 7},
                                                  {32, 5}, {64, 40}, {100, 9}, {256, 12}};
  for (auto [w, h] : shapes)
    for (const auto& s : varied_inputs(w, h, rng)) {
      std::vector<uint8_t> a, b;
      codec::encode_fast_body(s, w, h, a, Isa::kPortable);
      codec::encode_fast_body(s, w, h, b, Isa::kAvx2);
      ASSERT_EQ(a, b) << w << "x" << h;
    }
}

template <typename T>
void expect_both_decoders(std::span<const uint8_t> body, int bits, uint32_t w, uint32_t h,
                          const std::vector<T>* want) {
  auto parsed = codec::parse_fast_body(body, bits);
  if (!parsed) {
    ASSERT_EQ(want, nullptr) << parsed.error().describe();
    return;
  }
  std::vector<T> a(size_t(w) * h), b(size_t(w) * h);
  const Status sa = codec::decode_fast_body(*parsed, w, h, std::span<T>(a), Isa::kPortable);
  const Status sb = codec::decode_fast_body(*parsed, w, h, std::span<T>(b), Isa::kAvx2);
  ASSERT_EQ(sa.ok(), sb.ok());
  if (!sa.ok()) {
    EXPECT_EQ(sa.error().field, sb.error().field);
    EXPECT_EQ(want, nullptr) << sa.error().describe();
    return;
  }
  ASSERT_EQ(a, b) << w << "x" << h;
  if (want) {
    ASSERT_EQ(a, *want) << w << "x" << h;
  }
}

TEST(CodecFast, Avx2AndPortableDecodersAgreeOnValidAndDamagedBodies) {
  have_avx2();
  std::mt19937 rng(13);
  const std::pair<uint32_t, uint32_t> shapes[] = {{1, 1}, {5, 3}, {32, 4}, {40, 33}, {256, 9}};
  for (auto [w, h] : shapes)
    for (const auto& s : varied_inputs(w, h, rng)) {
      std::vector<uint8_t> body;
      codec::encode_fast_body(s, w, h, body);
      expect_both_decoders<uint16_t>(body, 16, w, h, &s);
      // Damaged copies: both paths must fail alike or decode the same (wrong) samples.
      for (int trial = 0; trial < 40; ++trial) {
        std::vector<uint8_t> bad = body;
        if (trial % 4 == 0) {
          bad.resize(rng() % bad.size());
        } else {
          bad[rng() % bad.size()] ^= uint8_t(1u << (rng() % 8));
        }
        expect_both_decoders<uint16_t>(bad, 16, w, h, nullptr);
      }
    }
}

TEST(CodecFast, DetailBodiesRoundTripOnBothDecoders) {
  std::mt19937 rng(14);
  for (auto [w, h] : {std::pair<uint32_t, uint32_t>{1, 1}, {7, 3}, {64, 64}, {256, 8}}) {
    std::vector<int8_t> s(size_t(w) * h);
    for (size_t i = 0; i < s.size(); ++i) s[i] = int8_t(i % 3 == 0 ? rng() : (i / w) % 7);
    std::vector<uint8_t> body;
    codec::encode_fast_body(s, w, h, body);
    expect_both_decoders<int8_t>(body, 8, w, h, &s);
  }
}

// --- Layout ----------------------------------------------------------------------------

// docs/codec.md, "fast": one row of four equal samples, so the plane residuals are 40, 0,
// 0, 0 (zigzag 80, 0, 0, 0) and every sample is in the first row's context 7. Pins the
// body byte for byte: preamble, eight tables, rANS length, 32 states, escape bits.
TEST(CodecFast, FastBodyBytesAreTheDocumentedLayout) {
  const std::vector<uint16_t> s = {40, 40, 40, 40};
  std::vector<uint8_t> body;
  codec::encode_fast_body(s, 4, 1, body, Isa::kPortable);
  std::vector<uint8_t> want = {0, 0};             // shift 0 (so no low bits), predictor 0 (plane)
  for (int c = 0; c < 7; ++c) want.push_back(0);  // contexts 0-6 unused
  // Context 7: tokens 0..34; z = 80 has bit width 7, so token 32 + 2 (7 - 6) + bit 5 of 80
  // (0) = 34. Counts 3 and 1 scale to 768 and 256, two-byte varints.
  want.push_back(35);
  want.push_back(0x80 | (768 & 0x7F));
  want.push_back(768 >> 7);
  for (int t = 1; t < 34; ++t) want.push_back(0);
  want.push_back(0x80 | (256 & 0x7F));
  want.push_back(256 >> 7);
  auto u32 = [&](uint32_t v) {
    for (int k = 0; k < 4; ++k) want.push_back(uint8_t(v >> (8 * k)));
  };
  u32(4 * codec::rans::kLanes);  // the states only: four symbols from 2^16 need no word
  // Symbol i used state i, starting at 2^16: x -> (x / f) * 1024 + x % f + start.
  u32((65536 / 256) * 1024 + 65536 % 256 + 768);  // token 34: start 768, frequency 256
  for (int i = 1; i < 4; ++i) u32((65536 / 768) * 1024 + 65536 % 768 + 0);  // token 0
  for (int i = 4; i < codec::rans::kLanes; ++i) u32(65536);
  // Escape bits: the 5 bits of 80 below its top two, 0b10000.
  want.push_back(0x10);
  EXPECT_EQ(body, want);
}

// --- Rejection of malformed bodies -----------------------------------------------------

std::vector<uint8_t> smooth_body(uint32_t w, uint32_t h, std::vector<uint16_t>* samples = nullptr) {
  std::vector<uint16_t> s(size_t(w) * h);
  for (size_t i = 0; i < s.size(); ++i)
    s[i] = uint16_t(5000 + (i % w) * 9 + (i / w) * 4 + (i * 40503u >> 13) % 60);
  if (samples) *samples = s;
  std::vector<uint8_t> body;
  codec::encode_fast_body(s, w, h, body);
  return body;
}

// Offset of the rANS length field in a body without shift (preamble: shift, predictor).
size_t rans_length_offset(const std::vector<uint8_t>& body) {
  size_t at = 2;
  for (int c = 0; c < codec::kContexts; ++c) {
    const uint32_t count = body[at++];
    for (uint32_t t = 0; t < count; ++t) at += (body[at] & 0x80) ? 2 : 1;
  }
  return at;
}

std::string parse_error_field(const std::vector<uint8_t>& body) {
  auto r = codec::parse_fast_body(body, 16);
  return r ? "" : r.error().field;
}
std::string decode_error_field(const std::vector<uint8_t>& body, uint32_t w, uint32_t h) {
  auto r = codec::parse_fast_body(body, 16);
  if (!r) return r.error().field;
  std::vector<uint16_t> out(size_t(w) * h);
  const Status s = codec::decode_fast_body(*r, w, h, std::span<uint16_t>(out));
  return s.ok() ? "" : s.error().field;
}

TEST(CodecFastReject, TablesWhoseFrequenciesDoNotSumTo1024AreCorrupt) {
  std::vector<uint8_t> body = smooth_body(32, 8);
  ASSERT_EQ(parse_error_field(body), "");
  // The first frequency of the first used context, one off (its lowest bit flipped, in the
  // first byte of either form).
  size_t at = 2;
  while (body[at] == 0) ++at;
  ++at;
  body[at] ^= 1;
  EXPECT_EQ(parse_error_field(body), "region.fast.tables");
}

TEST(CodecFastReject, TokenCountsAboveTheSampleTypesAlphabetAreCorrupt) {
  std::vector<uint8_t> body = smooth_body(16, 4);
  body[2] = uint8_t(codec::token_count(16) + 1);
  EXPECT_EQ(parse_error_field(body), "region.fast.tables");
  std::vector<uint8_t> detail = smooth_body(16, 4);
  detail[2] = uint8_t(codec::token_count(8) + 1);
  auto r = codec::parse_fast_body(detail, 8);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "region.fast.tables");
}

TEST(CodecFastReject, AFrequencyNotInItsShortestFormIsCorrupt) {
  // A body by hand: context 0 holds tokens 0 and 1 with frequencies 5 and 1019, the rest
  // are unused, 32 states of 2^16 and no words or escape bits.
  auto body_with = [](std::vector<uint8_t> five) {
    // Built by push_back: GCC 12 at -O3 misreads an insert after a 3-byte init (-Warray-bounds).
    std::vector<uint8_t> b;
    b.reserve(256);
    for (uint8_t v : {uint8_t(0), uint8_t(0), uint8_t(2)}) b.push_back(v);
    for (uint8_t v : five) b.push_back(v);
    b.push_back(0x80 | (1019 & 0x7F));
    b.push_back(1019 >> 7);
    for (int c = 1; c < 8; ++c) b.push_back(0);
    for (int v : {128, 0, 0, 0}) b.push_back(uint8_t(v));
    for (int i = 0; i < 32; ++i)
      for (int v : {0, 0, 1, 0}) b.push_back(uint8_t(v));
    return b;
  };
  EXPECT_EQ(parse_error_field(body_with({5})), "");
  EXPECT_EQ(parse_error_field(body_with({0x85, 0x00})), "region.fast.tables") << "5 in two bytes";
}

TEST(CodecFastReject, InitialStatesBelow2To16AreCorrupt) {
  std::vector<uint8_t> body = smooth_body(32, 8);
  const size_t at = rans_length_offset(body) + 4;
  body[at + 2] = 0;  // state 0 < 2^16
  body[at + 3] = 0;
  EXPECT_EQ(parse_error_field(body), "region.fast.rans");
}

TEST(CodecFastReject, ARansLengthBeyondTheBodyIsTruncatedAndAnOddOneCorrupt) {
  std::vector<uint8_t> body = smooth_body(32, 8);
  const size_t at = rans_length_offset(body);
  std::vector<uint8_t> longer = body;
  longer[at + 2] = 0x10;
  auto r = codec::parse_fast_body(longer, 16);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kTruncated);
  std::vector<uint8_t> odd = body;
  odd[at] = uint8_t(odd[at] | 1);
  EXPECT_EQ(parse_error_field(odd), "region.fast.rans");
}

TEST(CodecFastReject, WordsLeftOverOrMissingAreRejected) {
  std::vector<uint16_t> s;
  std::vector<uint8_t> body = smooth_body(64, 16, &s);
  ASSERT_EQ(decode_error_field(body, 64, 16), "");
  const size_t at = rans_length_offset(body);
  const uint32_t rans_bytes = uint32_t(body[at]) | (uint32_t(body[at + 1]) << 8) |
                              (uint32_t(body[at + 2]) << 16) | (uint32_t(body[at + 3]) << 24);
  ASSERT_GT(rans_bytes, 4u * codec::rans::kLanes) << "the test needs words";
  auto with_length = [&](std::vector<uint8_t> b, uint32_t len) {
    for (int k = 0; k < 4; ++k) b[at + size_t(k)] = uint8_t(len >> (8 * k));
    return b;
  };
  // Two more bytes at the end of the rANS section: left over.
  std::vector<uint8_t> more = with_length(body, rans_bytes + 2);
  more.insert(more.begin() + long(at + 4 + rans_bytes), {0, 0});
  EXPECT_EQ(decode_error_field(more, 64, 16), "region.fast.rans");
  // The first word missing: the stream runs out (or the states do not come back).
  std::vector<uint8_t> fewer = with_length(body, rans_bytes - 2);
  const long words = long(at + 4 + 4 * codec::rans::kLanes);
  fewer.erase(fewer.begin() + words, fewer.begin() + words + 2);
  EXPECT_EQ(decode_error_field(fewer, 64, 16), "region.fast.rans");
}

TEST(CodecFastReject, EscapeBitsLeftOverOrMissingAreRejected) {
  std::mt19937 rng(2);
  std::vector<uint16_t> s(64 * 16);
  for (auto& v : s) v = uint16_t(rng() % 4000);  // rough: many escapes
  std::vector<uint8_t> body;
  codec::encode_fast_body(s, 64, 16, body);
  ASSERT_EQ(decode_error_field(body, 64, 16), "");
  std::vector<uint8_t> more = body;
  more.push_back(0);
  EXPECT_EQ(decode_error_field(more, 64, 16), "region.fast.extras");
  std::vector<uint8_t> fewer = body;
  fewer.resize(fewer.size() - 1);
  EXPECT_EQ(decode_error_field(fewer, 64, 16), "region.fast.extras");
}

TEST(CodecFastReject, ShiftAboveTheSampleWidthLowBitsAboveTheShiftAndUnknownPredictorsAreCorrupt) {
  std::vector<uint8_t> body = {16};
  EXPECT_EQ(parse_error_field(body), "region.fast");
  body = {3, 8, 0};  // low 8 does not fit 3 bits
  EXPECT_EQ(parse_error_field(body), "region.fast");
  auto r = codec::parse_fast_body(std::vector<uint8_t>{1, 0, 0}, 8);  // detail has no shift
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().field, "region.fast");
  std::vector<uint8_t> good = smooth_body(16, 4);
  ASSERT_EQ(parse_error_field(good), "");
  good[1] = 2;  // predictors are 0 and 1
  EXPECT_EQ(parse_error_field(good), "region.fast");
}

// DEMs imported at a finer spacing than their source (etopo5, data/default_terrain) are
// bilinear patches whose plane residuals repeat down each cell: the encoder must notice
// and subtract the residual above (docs/codec.md: 6% smaller on default_terrain).
TEST(CodecFast, UpsampledTerrainIsCodedWithTheResidualAboveSubtracted) {
  std::mt19937 rng(8);
  const std::vector<uint16_t> s = upsampled(256, 64, rng);
  std::vector<uint8_t> chosen, smooth;
  codec::encode_fast_body(s, 256, 64, chosen);
  EXPECT_EQ(chosen[1], 1) << "predictor";
  expect_both_decoders<uint16_t>(chosen, 16, 256, 64, &s);
  const std::vector<uint8_t> plain = smooth_body(256, 64);
  EXPECT_EQ(plain[1], 0) << "a smooth noisy field keeps the plane";
}

}  // namespace
}  // namespace loam
