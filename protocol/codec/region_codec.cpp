#include "protocol/codec/region_codec.h"

#include <xxhash.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <memory>
#include <numeric>
#include <string>
#include <type_traits>

#include "protocol/byte_order.h"
#include "protocol/codec/fast_coder.h"
#include "protocol/codec/fast_coder_v2.h"
#include "protocol/codec/field_coder.h"
#include "protocol/codec/predictor.h"
#include "protocol/codec/range_coder.h"
#include "protocol/codec/refine_coder.h"
#include "protocol/layer.h"
#include "protocol/tile_hash.h"

namespace loam {

const char* to_string(RegionEncoding encoding) {
  switch (encoding) {
    case RegionEncoding::kRaw: return "raw";
    case RegionEncoding::kFast: return "fast";
    case RegionEncoding::kBest: return "best";
    case RegionEncoding::kDelta: return "delta";
    case RegionEncoding::kRefine: return "refine";
  }
  return "?";
}

namespace {

constexpr uint8_t kMagic0 = 'L', kMagic1 = 'R';
// 3: fast mode is plane prediction + contextual rANS (fast_coder.h), and refinement predicts
// differently. Version 2 payloads (snapshots written before) still decode where their
// layout is known: raw, fast (fast_coder_v2.h), best and delta; version 2 refinement and
// version 1 are rejected as unsupported.
constexpr uint8_t kFormatVersion = 3;
constexpr uint8_t kOldestFormatVersion = 2;

// Per sample type: the field domain of the samples themselves and of signed differences, from
// the layer's row (protocol/layer.h), and the type's tag in the header.
template <LayerRow R, SampleType kTag>
struct CodecTraits {
  static constexpr SampleType kType = kTag;
  static constexpr int kBits = R::kBits;
  static constexpr int32_t kLo = R::kMin;
};
template <typename T>
struct Traits;
template <>
struct Traits<CoarseLayer::Sample> : CodecTraits<CoarseLayer, SampleType::kCoarseU16> {};
template <>
struct Traits<DetailLayer::Sample> : CodecTraits<DetailLayer, SampleType::kDetailI8> {};

template <typename T>
int32_t wrap_signed(int32_t v) {  // v modulo 2^bits, in [-2^(bits-1), 2^(bits-1))
  constexpr int32_t span = int32_t(1) << Traits<T>::kBits;
  return ((v + span / 2) & (span - 1)) - span / 2;
}
template <typename T>
T wrap_sample(int32_t v) {  // v modulo 2^bits, as a sample
  if constexpr (std::is_unsigned_v<T>) {
    return T(v & ((int32_t(1) << Traits<T>::kBits) - 1));
  } else {
    return T(wrap_signed<T>(v));
  }
}

Status check_dims(uint32_t width, uint32_t height) {
  if (width == 0 || height == 0) return make_error(ErrorCode::kInvalidArgument, "region.size", "empty rect");
  if (width > kMaxRegionSide || height > kMaxRegionSide || uint64_t(width) * height > kMaxRegionSamples) {
    return make_error(ErrorCode::kOversize, "region.size",
                      std::to_string(width) + "x" + std::to_string(height) + " exceeds the region cap");
  }
  return {};
}

std::vector<uint8_t> with_header(RegionEncoding enc, SampleType type, uint32_t width, uint32_t height,
                                 std::vector<uint8_t> body_with_room) {
  // body_with_room starts with kRegionHeaderSize bytes reserved for the header.
  uint8_t* h = body_with_room.data();
  const size_t body_size = body_with_room.size() - kRegionHeaderSize;
  h[0] = kMagic0;
  h[1] = kMagic1;
  h[2] = kFormatVersion;
  h[3] = uint8_t(enc);
  h[4] = uint8_t(type);
  h[5] = 0;
  store_le<uint16_t>(h + 6, uint16_t(width));  // check_dims: at most kMaxRegionSide
  store_le<uint16_t>(h + 8, uint16_t(height));
  store_le<uint32_t>(h + 10, uint32_t(body_size));
  store_le<uint32_t>(h + 14, region_checksum(body_with_room));
  return body_with_room;
}

template <typename T>
std::vector<uint8_t> encode_raw(std::span<const T> s, uint32_t width, uint32_t height) {
  std::vector<uint8_t> out(kRegionHeaderSize + s.size() * sizeof(T));
  uint8_t* p = out.data() + kRegionHeaderSize;
  for (size_t i = 0; i < s.size(); ++i) {
    if constexpr (sizeof(T) == 2) {
      store_le<uint16_t>(p + 2 * i, s[i]);
    } else {
      p[i] = uint8_t(s[i]);
    }
  }
  return with_header(RegionEncoding::kRaw, Traits<T>::kType, width, height, std::move(out));
}

// Fast mode: the body is fast_coder.h's. The thread's scratch holds the payload being built,
// so a call allocates only the vector it returns.
template <typename T>
std::vector<uint8_t> encode_fast(std::span<const T> s, uint32_t width, uint32_t height) {
  thread_local std::vector<uint8_t> buffer;
  buffer.assign(kRegionHeaderSize, 0);
  codec::encode_fast_body(s, width, height, buffer);
  return with_header(RegionEncoding::kFast, Traits<T>::kType, width, height,
                     std::vector<uint8_t>(buffer.begin(), buffer.end()));
}

std::vector<uint8_t> start_body() { return std::vector<uint8_t>(kRegionHeaderSize, 0); }

// Reduction: real DEMs imported with a power-of-two step ratio (and integer stamp deltas
// of coarse steps) leave every sample on a lattice r + g*k. The entropy coder would spend
// log2(g) bits per sample on low bits that are always equal, so the field coder sees k and
// the body starts with (bits, g, r). docs/codec.md, "Reduction preamble".
struct Reduction {
  int bits = 16;  // the reduced values need this many bits (signed fields: including sign)
  uint32_t g = 1, r = 0;
};
constexpr size_t kReductionSize = 5;

// For non-negative values u (samples minus their type's lowest value).
Reduction find_reduction(std::span<const int32_t> u) {
  uint32_t g = 0;
  for (int32_t v : u) {
    g = std::gcd(g, uint32_t(std::abs(v - u[0])));
    if (g == 1) break;  // the common case for rough terrain: stop paying for gcd
  }
  Reduction red;
  red.g = g == 0 ? 1 : g;
  red.r = uint32_t(u[0]) % red.g;
  int32_t mx = 0;
  for (int32_t v : u) mx = std::max(mx, int32_t((uint32_t(v) - red.r) / red.g));
  red.bits = std::max(1, int(std::bit_width(uint32_t(mx))));
  return red;
}
// For signed values (deltas): r = 0 and one more bit for the sign.
Reduction find_signed_reduction(std::span<const int32_t> d) {
  uint32_t g = 0;
  for (int32_t v : d) {
    g = std::gcd(g, uint32_t(std::abs(v)));
    if (g == 1) break;
  }
  Reduction red;
  red.g = g == 0 ? 1 : g;
  uint32_t mx = 0;
  for (int32_t v : d) mx = std::max(mx, uint32_t(std::abs(v)) / red.g);
  red.bits = int(std::bit_width(mx)) + 1;
  return red;
}
void put_reduction(std::vector<uint8_t>& out, const Reduction& red) {
  out.push_back(uint8_t(red.bits));
  out.push_back(uint8_t(red.g));
  out.push_back(uint8_t(red.g >> 8));
  out.push_back(uint8_t(red.r));
  out.push_back(uint8_t(red.r >> 8));
}
// Reads and validates the preamble: the lattice must fit the sample type (`max_u` is the
// largest unsigned offset, `max_bits` the widest reduced field).
Result<Reduction> get_reduction(std::span<const uint8_t> body, uint32_t max_u, int max_bits) {
  if (body.size() < kReductionSize)
    return make_error(ErrorCode::kTruncated, "region.reduction", "body too short");
  Reduction red;
  red.bits = body[0];
  red.g = load_le<uint16_t>(body.data() + 1);
  red.r = load_le<uint16_t>(body.data() + 3);
  if (red.bits < 1 || red.bits > max_bits || red.g < 1 || red.r >= red.g || red.g > max_u + 1) {
    return make_error(ErrorCode::kCorrupt, "region.reduction", "bits/step/offset out of range");
  }
  return red;
}

template <typename T>
std::vector<uint8_t> encode_best(std::span<const T> s, uint32_t width, uint32_t height) {
  std::vector<int32_t> f(s.size());
  for (size_t i = 0; i < s.size(); ++i) f[i] = int32_t(s[i]) - Traits<T>::kLo;
  const Reduction red = find_reduction(f);
  for (int32_t& v : f) v = int32_t((uint32_t(v) - red.r) / red.g);
  std::vector<uint8_t> out = start_body();
  put_reduction(out, red);
  codec::RangeEncoder enc(out);
  codec::encode_field(f, {width, height, red.bits, 0}, enc);
  enc.finish();
  return with_header(RegionEncoding::kBest, Traits<T>::kType, width, height, std::move(out));
}

template <typename T>
std::vector<uint8_t> encode_delta(std::span<const T> s, std::span<const T> base, uint32_t width,
                                  uint32_t height) {
  std::vector<int32_t> f(s.size());
  for (size_t i = 0; i < s.size(); ++i) f[i] = wrap_signed<T>(int32_t(s[i]) - int32_t(base[i]));
  const Reduction red = find_signed_reduction(f);
  for (int32_t& v : f) v /= int32_t(red.g);
  std::vector<uint8_t> out = start_body();
  put_reduction(out, red);
  codec::RangeEncoder enc(out);
  codec::encode_field(f, {width, height, red.bits, -(int32_t(1) << (red.bits - 1))}, enc);
  enc.finish();
  return with_header(RegionEncoding::kDelta, Traits<T>::kType, width, height, std::move(out));
}

template <typename T>
std::vector<uint8_t> encode_refine(std::span<const T> s, uint32_t width, uint32_t height) {
  std::vector<int32_t> f(s.size());
  for (size_t i = 0; i < s.size(); ++i) f[i] = int32_t(s[i]) - Traits<T>::kLo;
  const Reduction red = find_reduction(f);
  for (int32_t& v : f) v = int32_t((uint32_t(v) - red.r) / red.g);
  std::vector<uint8_t> out = start_body();
  put_reduction(out, red);
  codec::RangeEncoder enc(out);
  codec::encode_refinement(enc, f, width, height, red.bits);
  enc.finish();
  return with_header(RegionEncoding::kRefine, Traits<T>::kType, width, height, std::move(out));
}

template <typename T>
Result<std::vector<uint8_t>> encode_any(RegionEncoding encoding, std::span<const T> s, uint32_t width,
                                        uint32_t height, const RegionRefs<T>& refs) {
  LOAM_TRY(check_dims(width, height));
  const size_t n = size_t(width) * height;
  if (s.size() != n) {
    return make_error(ErrorCode::kInvalidArgument, "region.samples",
                      std::to_string(s.size()) + " samples for a " + std::to_string(width) + "x" +
                          std::to_string(height) + " rect");
  }
  std::vector<uint8_t> out;
  switch (encoding) {
    case RegionEncoding::kRaw: return encode_raw(s, width, height);
    case RegionEncoding::kFast: out = encode_fast(s, width, height); break;
    case RegionEncoding::kBest: {
      // The blended predictor loses to plain MED + zstd on a few smooth tiles (its adaptive
      // models have too few samples to settle); both are decodable, so best keeps whichever
      // is smaller and the header says which was sent. Costs one fast encode (~1/20 of best).
      out = encode_best(s, width, height);
      std::vector<uint8_t> fast = encode_fast(s, width, height);
      if (!fast.empty() && fast.size() < out.size()) out = std::move(fast);
      break;
    }
    case RegionEncoding::kDelta:
      if (refs.base.size() != n)
        return make_error(ErrorCode::kInvalidArgument, "region.base", "base size differs");
      out = encode_delta(s, refs.base, width, height);
      break;
    case RegionEncoding::kRefine: {
      const size_t cw = (width + 1) / 2, ch = (height + 1) / 2;
      if (refs.coarser.size() != cw * ch) {
        return make_error(ErrorCode::kInvalidArgument, "region.coarser", "coarser mip size differs");
      }
      for (size_t y = 0; y < ch; ++y)
        for (size_t x = 0; x < cw; ++x)
          if (refs.coarser[y * cw + x] != s[2 * y * width + 2 * x]) {
            return make_error(ErrorCode::kInvalidArgument, "region.coarser",
                              "coarser mip does not match the rect's even samples");
          }
      out = encode_refine(s, width, height);
      break;
    }
    default: return make_error(ErrorCode::kBadEnum, "region.encoding", "unknown encoding");
  }
  // Raw is the floor: never send more than the samples themselves.
  if (out.empty() || out.size() >= kRegionHeaderSize + n * sizeof(T)) return encode_raw(s, width, height);
  return out;
}

template <typename T>
Result<std::vector<T>> decode_any(std::span<const uint8_t> payload, uint32_t width, uint32_t height,
                                  const RegionRefs<T>& refs, std::optional<uint64_t> expected_hash) {
  LOAM_TRY(check_dims(width, height));
  auto header = read_region_header(payload);
  if (!header) return header.error();
  const RegionHeader& hd = *header;
  if (hd.type != Traits<T>::kType) {
    return make_error(ErrorCode::kCorrupt, "region.type", "payload holds the other layer's sample type");
  }
  if (hd.width != width || hd.height != height) {
    return make_error(ErrorCode::kCorrupt, "region.size",
                      "payload is " + std::to_string(hd.width) + "x" + std::to_string(hd.height) +
                          ", rect is " + std::to_string(width) + "x" + std::to_string(height));
  }
  const std::span<const uint8_t> body = payload.subspan(kRegionHeaderSize, hd.body_size);
  if (region_checksum(payload) != hd.body_checksum) {
    return make_error(ErrorCode::kCorrupt, "region.checksum", "body checksum mismatch");
  }
  const size_t n = size_t(width) * height;
  // References are checked before the output is allocated.
  if (hd.encoding == RegionEncoding::kDelta && refs.base.size() != n) {
    return make_error(ErrorCode::kInvalidArgument, "region.base",
                      "delta needs the base rect (" + std::to_string(n) + " samples), got " +
                          std::to_string(refs.base.size()));
  }
  const size_t cw = (width + 1) / 2, ch = (height + 1) / 2;
  if (hd.encoding == RegionEncoding::kRefine && refs.coarser.size() != cw * ch) {
    return make_error(ErrorCode::kInvalidArgument, "region.coarser",
                      "refinement needs the coarser mip (" + std::to_string(cw * ch) + " samples), got " +
                          std::to_string(refs.coarser.size()));
  }
  if (hd.encoding == RegionEncoding::kRaw && body.size() != n * sizeof(T)) {
    return make_error(
        ErrorCode::kCorrupt, "region.raw",
        "body holds " + std::to_string(body.size()) + " bytes, rect needs " + std::to_string(n * sizeof(T)));
  }
  // Fast bodies are parsed (tables, section sizes) before the output is allocated.
  const bool legacy_fast = hd.encoding == RegionEncoding::kFast && hd.version == 2;
  codec::FastBody fast;
  codec::FastBodyV2 fast_v2;
  if (hd.encoding == RegionEncoding::kFast) {
    if (legacy_fast) {
      auto fb = codec::parse_fast_body_v2(body, sizeof(T), n);
      if (!fb) return fb.error();
      fast_v2 = *fb;
    } else {
      auto fb = codec::parse_fast_body(body, Traits<T>::kBits);
      if (!fb) return fb.error();
      fast = *fb;
    }
  }
  if (hd.encoding != RegionEncoding::kRaw && hd.encoding != RegionEncoding::kFast &&
      body.size() < kReductionSize + 5) {
    return make_error(ErrorCode::kTruncated, "region.stream",
                      "range coder stream shorter than its 5-byte flush");
  }

  std::vector<T> out(n);
  switch (hd.encoding) {
    case RegionEncoding::kRaw:
      for (size_t i = 0; i < n; ++i) {
        if constexpr (sizeof(T) == 2) {
          out[i] = uint16_t(load_le<uint16_t>(body.data() + 2 * i));
        } else {
          out[i] = int8_t(body[i]);
        }
      }
      break;
    case RegionEncoding::kFast:
      if (legacy_fast) {
        LOAM_TRY(codec::decode_fast_body_v2(fast_v2, width, height, std::span<T>(out)));
      } else {
        LOAM_TRY(codec::decode_fast_body(fast, width, height, std::span<T>(out)));
      }
      break;
    case RegionEncoding::kBest:
    case RegionEncoding::kDelta:
    case RegionEncoding::kRefine: {
      constexpr uint32_t max_u = (uint32_t(1) << Traits<T>::kBits) - 1;
      const bool is_delta = hd.encoding == RegionEncoding::kDelta;
      auto red = get_reduction(body, max_u, Traits<T>::kBits + (is_delta ? 1 : 0));
      if (!red) return red.error();
      const Reduction rd = *red;
      codec::RangeDecoder dec(body.subspan(kReductionSize));
      std::vector<int32_t> f(n);
      const char* field = "region.best";
      if (hd.encoding == RegionEncoding::kBest) {
        codec::decode_field(f, {width, height, rd.bits, 0}, dec);
      } else if (is_delta) {
        field = "region.delta";
        codec::decode_field(f, {width, height, rd.bits, -(int32_t(1) << (rd.bits - 1))}, dec);
      } else {
        field = "region.refine";
        const uint32_t top = (uint32_t(1) << rd.bits) - 1;
        for (size_t y = 0; y < ch; ++y)
          for (size_t x = 0; x < cw; ++x) {
            const uint32_t u = uint32_t(int32_t(refs.coarser[y * cw + x]) - Traits<T>::kLo);
            if (u < rd.r || (u - rd.r) % rd.g != 0 || (u - rd.r) / rd.g > top) {
              return make_error(ErrorCode::kCorrupt, "region.coarser",
                                "coarser mip is off the payload's sample lattice");
            }
            f[2 * y * width + 2 * x] = int32_t((u - rd.r) / rd.g);
          }
        codec::decode_refinement(dec, f, width, height, rd.bits);
      }
      if (dec.overran())
        return make_error(ErrorCode::kTruncated, field, "stream ended before the last sample");
      if (dec.remaining() != 0) {
        return make_error(ErrorCode::kCorrupt, field,
                          std::to_string(dec.remaining()) + " bytes after the last sample");
      }
      for (size_t i = 0; i < n; ++i) {
        if (is_delta) {
          out[i] = wrap_sample<T>(int32_t(int64_t(refs.base[i]) + int64_t(f[i]) * rd.g));
        } else {
          const uint64_t u = uint64_t(uint32_t(f[i])) * rd.g + rd.r;
          if (u > max_u)
            return make_error(ErrorCode::kCorrupt, field, "sample outside the sample type's range");
          out[i] = T(int32_t(u) + Traits<T>::kLo);
        }
      }
      break;
    }
  }
  if (expected_hash) {
    uint64_t got;
    if constexpr (sizeof(T) == 2) {
      got = hash_coarse_tile(out);
    } else {
      got = hash_detail_tile(out);
    }
    if (got != *expected_hash)
      return make_error(ErrorCode::kCorrupt, "region.hash", "decoded samples do not match the hash");
  }
  return out;
}

}  // namespace

uint32_t region_checksum(std::span<const uint8_t> payload) {
  if (payload.size() < kRegionHeaderSize) return 0;
  const uint64_t seed = XXH3_64bits(payload.data(), 14);
  return uint32_t(
      XXH3_64bits_withSeed(payload.data() + kRegionHeaderSize, payload.size() - kRegionHeaderSize, seed));
}

Result<RegionHeader> read_region_header(std::span<const uint8_t> payload) {
  if (payload.size() < kRegionHeaderSize) {
    return make_error(
        ErrorCode::kTruncated, "region.header",
        std::to_string(payload.size()) + " bytes, the header needs " + std::to_string(kRegionHeaderSize));
  }
  const uint8_t* p = payload.data();
  if (p[0] != kMagic0 || p[1] != kMagic1)
    return make_error(ErrorCode::kCorrupt, "region.magic", "not a region payload");
  if (p[2] < kOldestFormatVersion || p[2] > kFormatVersion) {
    return make_error(ErrorCode::kUnsupported, "region.version", "format version " + std::to_string(p[2]));
  }
  if (p[3] >= kRegionEncodingCount) {
    return make_error(ErrorCode::kBadEnum, "region.encoding", "encoding " + std::to_string(p[3]));
  }
  if (p[2] < kFormatVersion && RegionEncoding(p[3]) == RegionEncoding::kRefine) {
    return make_error(ErrorCode::kUnsupported, "region.version",
                      "version 2 refinement payloads are not decoded");
  }
  if (p[4] > uint8_t(SampleType::kDetailI8)) {
    return make_error(ErrorCode::kBadEnum, "region.type", "sample type " + std::to_string(p[4]));
  }
  if (p[5] != 0)
    return make_error(ErrorCode::kUnsupported, "region.flags", "unknown flags " + std::to_string(p[5]));
  RegionHeader h;
  h.version = p[2];
  h.encoding = RegionEncoding(p[3]);
  h.type = SampleType(p[4]);
  h.width = load_le<uint16_t>(p + 6);
  h.height = load_le<uint16_t>(p + 8);
  h.body_size = load_le<uint32_t>(p + 10);
  h.body_checksum = load_le<uint32_t>(p + 14);
  LOAM_TRY(check_dims(h.width, h.height));
  if (h.body_size != payload.size() - kRegionHeaderSize) {
    return make_error(
        h.body_size > payload.size() - kRegionHeaderSize ? ErrorCode::kTruncated : ErrorCode::kCorrupt,
        "region.body_size",
        "header says " + std::to_string(h.body_size) + " body bytes, payload has " +
            std::to_string(payload.size() - kRegionHeaderSize));
  }
  return h;
}

Result<std::vector<uint8_t>> encode_region(RegionEncoding encoding, std::span<const uint16_t> samples,
                                           uint32_t width, uint32_t height,
                                           const RegionRefs<uint16_t>& refs) {
  return encode_any(encoding, samples, width, height, refs);
}
Result<std::vector<uint8_t>> encode_region(RegionEncoding encoding, std::span<const int8_t> samples,
                                           uint32_t width, uint32_t height, const RegionRefs<int8_t>& refs) {
  return encode_any(encoding, samples, width, height, refs);
}
Result<std::vector<uint16_t>> decode_region(std::span<const uint8_t> payload, uint32_t width, uint32_t height,
                                            const RegionRefs<uint16_t>& refs,
                                            std::optional<uint64_t> expected_hash) {
  return decode_any(payload, width, height, refs, expected_hash);
}
Result<std::vector<int8_t>> decode_detail_region(std::span<const uint8_t> payload, uint32_t width,
                                                 uint32_t height, const RegionRefs<int8_t>& refs,
                                                 std::optional<uint64_t> expected_hash) {
  return decode_any(payload, width, height, refs, expected_hash);
}

}  // namespace loam
