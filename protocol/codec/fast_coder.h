// The region codec's fast mode body (format version 3): plane prediction, residual tokens
// in eight contexts from the row above, static interleaved rANS. docs/codec.md, "fast",
// gives the byte layout.
//
// Prediction is the plane W + N - NW (first row: W; first column: N; first sample: 0),
// modulo 2^bits, or, chosen per payload, the plane minus the plane residual one row up
// (for DEMs upsampled from a coarser grid, whose plane residuals repeat down each cell).
// The inverse is a running sum along each row added to the row above, with no per-sample
// branch or data-dependent chain longer than one add, which is what lets the decoder run
// at memory-like speeds. MED, the textbook choice, needs a serial min/max chain through W;
// with these contexts it is 2-5% smaller on four of the DEMs here and 4-14% larger on four
// others (docs/codec.md, "why this design").
//
// Safety on untrusted input: parse_fast_body validates every field of the body (preamble,
// frequency tables, section sizes, initial states) before the caller allocates anything;
// decode_fast_body reads only inside the parsed sections (word reads are bounded row by
// row; reading past the end of a section is reported as truncation) and checks that both
// sections are consumed exactly and that every rANS state returns to its initial value.
#pragma once

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "protocol/codec/predictor.h"
#include "protocol/codec/rans.h"
#include "protocol/codec/residual_tokens.h"
#include "protocol/result.h"

namespace loam::codec {

// Appends the fast body of width x height row-major samples to `out`. Every `isa` writes
// the same bytes (AVX2 kernels run where the CPU has them; tests force the portable ones).
void encode_fast_body(std::span<const uint16_t> samples, uint32_t width, uint32_t height,
                      std::vector<uint8_t>& out, Isa isa = detected_isa());
void encode_fast_body(std::span<const int8_t> samples, uint32_t width, uint32_t height,
                      std::vector<uint8_t>& out, Isa isa = detected_isa());

// A validated fast body: its preamble and tables, and views of its two coded sections.
struct FastBody {
  uint32_t shift = 0, low = 0;
  uint32_t predictor = 0;  // 0 plane, 1 plane minus the plane residual above
  std::array<std::array<uint16_t, kMaxTokens>, kContexts> freqs{};  // all zero: context unused
  std::array<uint32_t, rans::kLanes> states{};
  std::span<const uint8_t> words;   // the rANS word stream after the states
  std::span<const uint8_t> extras;  // the raw bits of escape tokens
};

// Checks the body of a fast payload for samples of `bits` bits (16 coarse, 8 detail).
// Errors name the field: region.fast (preamble), region.fast.tables, region.fast.rans.
Result<FastBody> parse_fast_body(std::span<const uint8_t> body, int bits);

// Decodes a parsed body into `out` (width * height samples). Errors: region.fast.rans,
// region.fast.extras (kTruncated when a section ends early, kCorrupt when bytes are left
// over or the states do not return to their start). Every `isa` decodes the same samples
// (the AVX2 token decoder runs where the CPU has it; tests force the portable one).
Status decode_fast_body(const FastBody& body, uint32_t width, uint32_t height, std::span<uint16_t> out,
                        Isa isa = detected_isa());
Status decode_fast_body(const FastBody& body, uint32_t width, uint32_t height, std::span<int8_t> out,
                        Isa isa = detected_isa());

}  // namespace loam::codec
