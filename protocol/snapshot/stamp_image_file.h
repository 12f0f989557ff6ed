// The byte format of a stored texture-stamp image (<data>/images/<id>.loamimg), encoded and
// decoded in memory so the fuzzer drives exactly what recovery runs (server/stamp_image_store
// does the file I/O).
//
// "LOAMIMG\n", u32 width, u32 height, width*height u16 samples (little-endian, row 0 first),
// then the XXH3-64 of everything before it. Safe on untrusted input: the side lengths are
// checked against kMaxTextureSide and the byte count against the buffer before anything is
// allocated, the checksum is verified and the content id recomputed; every failure is an
// Error naming `name`. Never throws.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "protocol/result.h"
#include "protocol/stamps/texture_registry.h"

namespace loam {

std::vector<uint8_t> encode_stamp_image(const StampTexture& t);
// The decoded image with its content id (texture_content_id) set.
Result<StampTexture> decode_stamp_image(std::span<const uint8_t> bytes, const std::string& name);
// The largest valid file (a kMaxTextureSide² image).
uint64_t max_stamp_image_file_bytes();

}  // namespace loam
