// Region codec: turns a rect of coarse (uint16) or detail (int8) samples into the payload of
// a RegionUpdate and back, losslessly. It is the bandwidth budget of every join, reconnect
// and repair. docs/codec.md gives the byte layout and the measured costs.
//
// Encodings (the payload's first bytes say which one was used):
//   kRaw    samples as little-endian bytes; the fallback when nothing else is smaller.
//   kFast   plane predictor, residual tokens in contexts from the row above, static
//           interleaved rANS: streaming speed (fast_coder.h).
//   kBest   blended context-adaptive predictor with bias correction and a context-modelled
//           binary arithmetic coder: the smallest payload, ~10x slower than kFast. Where
//           the kFast payload is smaller, that is what comes back (the header says so).
//   kDelta  new - base over the same rect (the base is a version the receiver holds),
//           coded like kBest; smooth stamp deltas cost a few bytes.
//   kRefine the samples of mip m-1 given mip m: only the 3/4 of samples mip m does not hold
//           are coded, predicted by interpolation from the ones it does.
// Encoders fall back to kRaw when their payload would not be smaller.
//
// Safety on untrusted input: decode_region() accepts any byte span. It checks the header
// against the dimensions the caller expects (taken from the RegionUpdate's rect) before
// allocating anything, bounds every read, checks a body checksum, and returns an Error
// naming the field on any corrupt, truncated or inconsistent payload; it never throws,
// never reads outside the payload, and never allocates more than the expected rect
// (kMaxRegionSamples at most) plus the payload size. With an expected hash it also checks
// the decoded samples against it.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "protocol/result.h"

namespace loam {

enum class RegionEncoding : uint8_t { kRaw = 0, kFast = 1, kBest = 2, kDelta = 3, kRefine = 4 };
inline constexpr int kRegionEncodingCount = 5;
const char* to_string(RegionEncoding encoding);

enum class SampleType : uint8_t { kCoarseU16 = 0, kDetailI8 = 1 };

inline constexpr uint32_t kMaxRegionSide = 4096;                                // width, height
inline constexpr uint64_t kMaxRegionSamples = uint64_t(kMaxRegionSide) * 1024;  // 4M samples
inline constexpr size_t kRegionHeaderSize = 18;

// What a payload's header says (see docs/codec.md for the byte layout).
struct RegionHeader {
  uint8_t version = 0;  // format version: 3, or 2 for older payloads that still decode
  RegionEncoding encoding = RegionEncoding::kRaw;
  SampleType type = SampleType::kCoarseU16;
  uint32_t width = 0, height = 0;
  uint32_t body_size = 0;
  uint32_t body_checksum = 0;
};

// Reads and checks the header only (magic, version, enums, sizes, body length). Safe on any
// input. It does not check the checksum; decode_region() does. Version 2 headers of the
// encodings whose version 2 body still decodes (raw, fast, best, delta) are accepted.
Result<RegionHeader> read_region_header(std::span<const uint8_t> payload);

// Samples the receiver already holds, needed by some encodings.
//   base:    kDelta: the same rect at the base version (width*height samples).
//   coarser: kRefine: the samples of mip m for this mip m-1 rect, i.e. the samples at even
//            (x, y) of the rect, row-major, ceil(width/2) * ceil(height/2) of them. The
//            rect's origin must be even in the mip m-1 grid (tile rects always are).
template <typename T>
struct RegionRefs {
  std::span<const T> base;
  std::span<const T> coarser;
};

// Encodes width x height row-major samples. kDelta needs refs.base, kRefine refs.coarser
// (which must equal the samples at even positions: the encoder checks it). Any encoding may
// come back as kRaw when it would not be smaller. Errors: sizes out of range or not matching
// (kInvalidArgument / kOversize), a missing or inconsistent reference.
Result<std::vector<uint8_t>> encode_region(RegionEncoding encoding, std::span<const uint16_t> samples,
                                           uint32_t width, uint32_t height,
                                           const RegionRefs<uint16_t>& refs = {});
Result<std::vector<uint8_t>> encode_region(RegionEncoding encoding, std::span<const int8_t> samples,
                                           uint32_t width, uint32_t height,
                                           const RegionRefs<int8_t>& refs = {});

// Decodes a payload into width x height samples, where width and height are what the
// receiver expects (the RegionUpdate's rect); a header with other dimensions or another
// sample type is an error before anything is allocated. Delta and refinement payloads need
// the matching refs (sizes are checked). With expected_hash, the decoded samples must hash
// to it (hash_coarse_tile / hash_detail_tile over the decoded samples: for a whole tile that
// is the tile hash) or the result is a kCorrupt error on "region.hash".
Result<std::vector<uint16_t>> decode_region(std::span<const uint8_t> payload, uint32_t width, uint32_t height,
                                            const RegionRefs<uint16_t>& refs = {},
                                            std::optional<uint64_t> expected_hash = {});
Result<std::vector<int8_t>> decode_detail_region(std::span<const uint8_t> payload, uint32_t width,
                                                 uint32_t height, const RegionRefs<int8_t>& refs = {},
                                                 std::optional<uint64_t> expected_hash = {});

// The decoder of a sample type, for code generic over layers (protocol/layer.h).
template <typename T>
Result<std::vector<T>> decode_samples(std::span<const uint8_t> payload, uint32_t width, uint32_t height,
                                      const RegionRefs<T>& refs = {},
                                      std::optional<uint64_t> expected_hash = {});
template <>
inline Result<std::vector<uint16_t>> decode_samples(std::span<const uint8_t> payload, uint32_t width,
                                                    uint32_t height, const RegionRefs<uint16_t>& refs,
                                                    std::optional<uint64_t> expected_hash) {
  return decode_region(payload, width, height, refs, expected_hash);
}
template <>
inline Result<std::vector<int8_t>> decode_samples(std::span<const uint8_t> payload, uint32_t width,
                                                  uint32_t height, const RegionRefs<int8_t>& refs,
                                                  std::optional<uint64_t> expected_hash) {
  return decode_detail_region(payload, width, height, refs, expected_hash);
}

// The checksum the header carries: the low 32 bits of XXH3-64 over the header's first 14
// bytes and the body, so a flipped bit anywhere in the payload is caught. `payload` must
// hold at least the header. Exposed for the fuzz target and tests, which repair it so that
// mutations reach the entropy decoders.
uint32_t region_checksum(std::span<const uint8_t> payload);

}  // namespace loam
