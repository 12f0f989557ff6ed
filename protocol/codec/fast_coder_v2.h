// Decoder of the fast mode body of format version 2 (MED residual byte planes, one zstd
// frame per plane). Nothing encodes it any more; server snapshots written before version 3
// hold such payloads, so they stay readable. docs/codec.md, "fast (version 2)".
//
// Safety on untrusted input: parse_fast_body_v2 checks the preamble and that each frame
// declares exactly one plane of content before anything is allocated; decoding rejects a
// frame that does not produce exactly its plane.
#pragma once

#include <cstdint>
#include <span>

#include "protocol/result.h"

namespace loam::codec {

struct FastBodyV2 {
  uint32_t shift = 0, low = 0;
  std::span<const uint8_t> frames[2];  // the second is empty for int8 samples
};

// `planes` is 2 for coarse (uint16) samples, 1 for detail (int8); n = width * height.
Result<FastBodyV2> parse_fast_body_v2(std::span<const uint8_t> body, size_t planes, size_t n);
Status decode_fast_body_v2(const FastBodyV2& body, uint32_t width, uint32_t height, std::span<uint16_t> out);
Status decode_fast_body_v2(const FastBodyV2& body, uint32_t width, uint32_t height, std::span<int8_t> out);

}  // namespace loam::codec
