// libFuzzer target for the region codec decoder (decode_region / decode_detail_region).
// Input: one control byte, then a payload as a hostile server (or a corrupted link) would
// send it; the seed corpus (fuzz/corpus/codec_fuzz/) holds real payloads of every mode.
//   control bit 0: repair the header checksum first, so mutations of the body reach the
//                  entropy decoders instead of stopping at the checksum;
//   control bit 1: decode as the detail layer (int8) instead of coarse (uint16);
//   control bit 2: pass the header's dimensions as the expected rect (else a fixed 16x16,
//                  exercising the dimension check).
// Beyond "no crash, no sanitizer report" it checks that whatever decodes re-encodes (in the
// same mode) to a payload that decodes to the same samples, and that the fast mode's
// portable and AVX2 decoders agree on every body (same samples, or the same error field).
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <span>
#include <vector>

#include "protocol/codec/fast_coder.h"
#include "protocol/codec/region_codec.h"

namespace {

using namespace loam;

// Keeps every run fast: rects above this many samples are decoded with another size.
constexpr uint64_t kFuzzMaxSamples = 64 * 64;

[[noreturn]] void fail(const char* what) {
  std::fprintf(stderr, "codec_fuzz property violated: %s\n", what);
  std::abort();
}

// The two fast decoders on the body as it is (checksum or not).
template <typename T>
void check_fast_isas(std::span<const uint8_t> payload, uint32_t w, uint32_t h) {
  auto header = read_region_header(payload);
  if (!header.ok() || header->encoding != RegionEncoding::kFast || header->version != 3) return;
  auto body = codec::parse_fast_body(payload.subspan(kRegionHeaderSize), sizeof(T) * 8);
  if (!body.ok()) return;
  std::vector<T> a(size_t(w) * h), b(size_t(w) * h);
  const Status sa = codec::decode_fast_body(*body, w, h, std::span<T>(a), codec::Isa::kPortable);
  const Status sb = codec::decode_fast_body(*body, w, h, std::span<T>(b), codec::Isa::kAvx2);
  if (sa.ok() != sb.ok()) fail("fast decoders disagree on success");
  if (!sa.ok() && sa.error().field != sb.error().field) fail("fast decoders fail on different fields");
  if (sa.ok() && a != b) fail("fast decoders decode different samples");
}

template <typename T>
void check(std::span<const uint8_t> payload, uint32_t w, uint32_t h) {
  check_fast_isas<T>(payload, w, h);
  const size_t n = size_t(w) * h;
  std::vector<T> base(n), coarser(size_t((w + 1) / 2) * ((h + 1) / 2));
  for (size_t i = 0; i < base.size(); ++i) base[i] = T(i * 37 + 11);
  for (size_t i = 0; i < coarser.size(); ++i) coarser[i] = T(i * 5);
  const RegionRefs<T> refs{.base = base, .coarser = coarser};
  Result<std::vector<T>> decoded = std::vector<T>{};
  if constexpr (sizeof(T) == 2) {
    decoded = decode_region(payload, w, h, refs);
  } else {
    decoded = decode_detail_region(payload, w, h, refs);
  }
  if (!decoded.ok()) return;
  if (decoded->size() != n) fail("decoded size differs from the rect");
  auto header = read_region_header(payload);
  if (!header.ok()) fail("decoded a payload whose header does not parse");
  // Refinement needs a coarser mip consistent with the samples: take it from them.
  std::vector<T> even;
  for (uint32_t y = 0; y < h; y += 2)
    for (uint32_t x = 0; x < w; x += 2) even.push_back((*decoded)[size_t(y) * w + x]);
  const RegionRefs<T> again_refs{.base = base, .coarser = even};
  auto again = encode_region(header->encoding, std::span<const T>(*decoded), w, h, again_refs);
  if (!again.ok()) fail("decoded samples do not re-encode");
  Result<std::vector<T>> back = std::vector<T>{};
  if constexpr (sizeof(T) == 2) {
    back = decode_region(*again, w, h, again_refs);
  } else {
    back = decode_detail_region(*again, w, h, again_refs);
  }
  if (!back.ok() || *back != *decoded) fail("re-encoded samples do not round-trip");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const uint8_t control = data[0];
  std::vector<uint8_t> payload(data + 1, data + size);
  if ((control & 1) && payload.size() >= kRegionHeaderSize) {
    const uint32_t c = region_checksum(payload);
    for (int k = 0; k < 4; ++k) payload[size_t(14 + k)] = uint8_t(c >> (8 * k));
  }
  uint32_t w = 16, h = 16;
  if (control & 4) {
    auto header = read_region_header(payload);
    if (header.ok() && uint64_t(header->width) * header->height <= kFuzzMaxSamples) {
      w = header->width;
      h = header->height;
    }
  }
  if (control & 2) {
    check<int8_t>(payload, w, h);
  } else {
    check<uint16_t>(payload, w, h);
  }
  return 0;
}
