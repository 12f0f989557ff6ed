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

// `values` (width*height, row-major, each in range) is used as scratch and left unchanged.
// `side` is optional extra activity per sample (same size) that both ends can compute, e.g.
// the local slope of an interpolation; it only steers contexts.
void encode_field(std::span<int32_t> values, const FieldShape& shape, RangeEncoder& enc,
                  std::span<const int32_t> side = {});
// Fills `out` (width*height). Always succeeds as far as memory is concerned; check
// dec.overran() afterwards.
void decode_field(std::span<int32_t> out, const FieldShape& shape, RangeDecoder& dec,
                  std::span<const int32_t> side = {});

}  // namespace loam::codec
