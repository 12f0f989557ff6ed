// Field coder: the lossless context-modelling stage behind the region codec's best, delta
// and refinement modes.
//
// A field is a width x height grid of integers taken modulo 2^bits, each represented in
// [lo, lo + 2^bits): lo = 0 for heights (uint16: bits 16; int8 detail shifted: bits 8) and
// lo = -2^(bits-1) for signed fields (deltas, interpolation residuals). Each sample is
// predicted causally by blending several simple predictors (W, N, planes, linear
// extrapolations) with weights from their recent local errors, corrected by a per-context
// bias (CALIC-style), and the residual is coded by the binary range coder with zero, sign,
// exponent and the top mantissa bits modelled in contexts of local error energy.
//
// Safety on untrusted input: decode_field writes exactly the span it is given (sized by the
// caller from validated dimensions) and reads only through RangeDecoder, which is bounded.
// Any input decodes to some field in range; the caller rejects overrun streams.
#pragma once

#include <cstdint>
#include <span>

#include "protocol/codec/range_coder.h"

namespace loam::codec {

struct FieldShape {
  uint32_t width = 0;
  uint32_t height = 0;
  int bits = 16;   // 1..17
  int32_t lo = 0;  // values lie in [lo, lo + 2^bits)
};

// Predictions both ends can compute besides the causal ones, blended with them by the same
// error weighting: `count` per sample, sample i's at values[i * count + k]. Values should
// lie near the field's domain (they are only predictions; the result is clamped).
inline constexpr int kMaxExtraCandidates = 4;
// Candidate k whose bit is set in `w_relative` is W (the causal left neighbour in the field,
// as for the built-in candidates) plus values[i * count + k].
struct ExtraCandidates {
  std::span<const int32_t> values;
  uint32_t count = 0;  // <= kMaxExtraCandidates
  uint32_t w_relative = 0;
};

// `values` (width*height, row-major, each in range) is used as scratch and left unchanged.
void encode_field(std::span<int32_t> values, const FieldShape& shape, RangeEncoder& enc,
                  const ExtraCandidates& extra = {});
// Fills `out` (width*height). Always succeeds as far as memory is concerned; check
// dec.overran() afterwards.
void decode_field(std::span<int32_t> out, const FieldShape& shape, RangeDecoder& dec,
                  const ExtraCandidates& extra = {});

}  // namespace loam::codec
