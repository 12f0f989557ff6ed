// The refinement mode's coder: the samples of mip m-1 given those of mip m (the rect's
// samples at even x and y), in three interpolation passes coded with the field coder.
// docs/codec.md, "refine", states the passes.
//
// Safety on untrusted input: decode_refinement writes only inside `v` (width * height,
// sized by the caller from validated dimensions) and reads only through RangeDecoder, which
// is bounded; every decoded value is reduced into [0, 2^bits). The caller rejects overrun
// streams.
#pragma once

#include <cstdint>
#include <span>

#include "protocol/codec/range_coder.h"

namespace loam::codec {

// `v` holds the reduced rect (values in [0, 2^bits), 1 <= bits <= 16), row-major.
void encode_refinement(RangeEncoder& enc, std::span<int32_t> v, uint32_t width, uint32_t height, int bits);
// `v` has the even samples filled; the others are written.
void decode_refinement(RangeDecoder& dec, std::span<int32_t> v, uint32_t width, uint32_t height, int bits);

}  // namespace loam::codec
