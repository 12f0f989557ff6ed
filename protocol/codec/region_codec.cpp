#include "protocol/codec/region_codec.h"

#include <xxhash.h>
#include <zstd.h>

#include <algorithm>
#include <bit>
#include <cstring>
#include <memory>
#include <numeric>
#include <string>
#include <type_traits>

#include "protocol/codec/field_coder.h"
#include "protocol/codec/predictor.h"
#include "protocol/codec/range_coder.h"
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
// 2: fast mode codes its byte planes as separate frames and sends `low` only when shift > 0.
// Version 1 payloads are rejected.
constexpr uint8_t kFormatVersion = 2;

void put_u16(uint8_t* p, uint32_t v) {
  p[0] = uint8_t(v);
  p[1] = uint8_t(v >> 8);
}
void put_u32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = uint8_t(v >> (8 * i));
}
uint32_t get_u16(const uint8_t* p) { return uint32_t(p[0]) | (uint32_t(p[1]) << 8); }
uint32_t get_u32(const uint8_t* p) {
  return uint32_t(p[0]) | (uint32_t(p[1]) << 8) | (uint32_t(p[2]) << 16) | (uint32_t(p[3]) << 24);
}

Error err(ErrorCode code, const char* field, std::string message) {
  return make_error(code, field, std::move(message));
}

// zstd contexts are reused per thread: creating one costs more than compressing a tile.
struct ZstdDeleter {
  void operator()(ZSTD_CCtx* c) const { ZSTD_freeCCtx(c); }
  void operator()(ZSTD_DCtx* d) const { ZSTD_freeDCtx(d); }
};
// Fast mode's zstd settings, set once (they stick to the context across ZSTD_compress2).
// Level 1's fast strategy with minimum match 7 and a 4K-entry hash table: residual planes
// have few long repeats, so the shorter matches level 1 would try cost time and, coded as
// sequences, usually more bytes than the Huffman-coded literals they replace (measured:
// 8% fewer instructions and 0.2% smaller on the DEMs in data/ and ../shared/data/).
ZSTD_CCtx* fast_cctx() {
  thread_local const std::unique_ptr<ZSTD_CCtx, ZstdDeleter> c = [] {
    std::unique_ptr<ZSTD_CCtx, ZstdDeleter> p(ZSTD_createCCtx());
    if (p) {
      // A parameter the library refused leaves its default: still a valid frame.
      (void)ZSTD_CCtx_setParameter(p.get(), ZSTD_c_compressionLevel, 1);
      (void)ZSTD_CCtx_setParameter(p.get(), ZSTD_c_minMatch, 7);
      (void)ZSTD_CCtx_setParameter(p.get(), ZSTD_c_hashLog, 12);
      (void)ZSTD_CCtx_setParameter(p.get(), ZSTD_c_contentSizeFlag, 1);
    }
    return p;
  }();
  return c.get();
}
ZSTD_DCtx* dctx() {
  thread_local const std::unique_ptr<ZSTD_DCtx, ZstdDeleter> d(ZSTD_createDCtx());
  return d.get();
}
// Per-thread scratch for the fast mode (residual planes, compressed body): after the first
// region of a size, encoding and decoding allocate nothing but the vector they return.
struct FastScratch {
  std::vector<uint8_t> planes, body;
};
FastScratch& fast_scratch() {
  thread_local FastScratch s;
  return s;
}
uint8_t* grown(std::vector<uint8_t>& v, size_t n) {
  if (v.size() < n) v.resize(n);
  return v.data();
}

// Per sample type: the field domain of the samples themselves and of signed differences.
template <typename T>
struct Traits;
template <>
struct Traits<uint16_t> {
  static constexpr SampleType kType = SampleType::kCoarseU16;
  static constexpr int kBits = 16;
  static constexpr int32_t kLo = 0;
};
template <>
struct Traits<int8_t> {
  static constexpr SampleType kType = SampleType::kDetailI8;
  static constexpr int kBits = 8;
  static constexpr int32_t kLo = -128;
};

template <typename T>
int32_t wrap_signed(int32_t v) {  // v modulo 2^bits, in [-2^(bits-1), 2^(bits-1))
  constexpr int32_t span = int32_t(1) << Traits<T>::kBits;
  return ((v + span / 2) & (span - 1)) - span / 2;
}
template <typename T>
T wrap_sample(int32_t v) {  // v modulo 2^bits, as a sample
  if constexpr (std::is_same_v<T, uint16_t>) {
    return uint16_t(v & 0xFFFF);
  } else {
    return int8_t(wrap_signed<int8_t>(v));
  }
}

Status check_dims(uint32_t width, uint32_t height) {
  if (width == 0 || height == 0) return err(ErrorCode::kInvalidArgument, "region.size", "empty rect");
  if (width > kMaxRegionSide || height > kMaxRegionSide || uint64_t(width) * height > kMaxRegionSamples) {
    return err(ErrorCode::kOversize, "region.size",
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
  put_u16(h + 6, width);
  put_u16(h + 8, height);
  put_u32(h + 10, uint32_t(body_size));
  put_u32(h + 14, region_checksum(body_with_room));
  return body_with_room;
}

template <typename T>
std::vector<uint8_t> encode_raw(std::span<const T> s, uint32_t width, uint32_t height) {
  std::vector<uint8_t> out(kRegionHeaderSize + s.size() * sizeof(T));
  uint8_t* p = out.data() + kRegionHeaderSize;
  for (size_t i = 0; i < s.size(); ++i) {
    if constexpr (sizeof(T) == 2) {
      put_u16(p + 2 * i, s[i]);
    } else {
      p[i] = uint8_t(s[i]);
    }
  }
  return with_header(RegionEncoding::kRaw, Traits<T>::kType, width, height, std::move(out));
}

// Fast mode's reduction: when every sample shares its low `shift` bits (a DEM imported with
// a power-of-two step ratio), MED runs on the samples shifted right, so zstd sees residuals
// 2^shift times smaller. Only powers of two, so finding it is one OR pass and undoing it one
// shift, both vectorizable. Body: shift (u8), low bits (u16, only when shift > 0), then one
// zstd frame per residual byte plane (uint16: low bytes, then high bytes; int8: one).
// Separate frames give each plane its own Huffman table: the low bytes spread over many
// values, the high bytes are nearly all zero, and one table for both costs 1-11% more.
template <typename T>
std::vector<uint8_t> encode_fast(std::span<const T> s, uint32_t width, uint32_t height) {
  ZSTD_CCtx* cc = fast_cctx();
  if (cc == nullptr) return {};
  const size_t n = s.size();
  FastScratch& scratch = fast_scratch();
  constexpr size_t kPlanes = sizeof(T);
  uint8_t* planes = grown(scratch.planes, kPlanes * n);
  const size_t cap = kRegionHeaderSize + 3 + kPlanes * ZSTD_compressBound(n);
  uint8_t* out = grown(scratch.body, cap);
  size_t at = kRegionHeaderSize;
  if constexpr (sizeof(T) == 2) {
    uint32_t diff = 0;
    const uint16_t first = s[0];
    for (uint16_t v : s) diff |= uint32_t(v ^ first);
    const uint32_t shift = diff == 0 ? 0 : uint32_t(std::countr_zero(diff));
    out[at++] = uint8_t(shift);
    if (shift > 0) {
      put_u16(out + at, first & ((1u << shift) - 1));
      at += 2;
    }
    codec::med_forward_u16(s, width, height, shift, {planes, n}, {planes + n, n});
  } else {
    out[at++] = 0;
    codec::med_forward_i8(s, width, height, {planes, n});
  }
  for (size_t p = 0; p < kPlanes; ++p) {
    const size_t z = ZSTD_compress2(cc, out + at, cap - at, planes + p * n, n);
    if (ZSTD_isError(z)) return {};
    at += z;
  }
  return with_header(RegionEncoding::kFast, Traits<T>::kType, width, height,
                     std::vector<uint8_t>(out, out + at));
}

// Splits and checks a fast body before anything is allocated: the preamble must fit the
// sample type and each frame must declare exactly one plane (n bytes) of content.
struct FastBody {
  uint32_t shift = 0, low = 0;
  std::span<const uint8_t> frames[2];
};
template <typename T>
Result<FastBody> parse_fast(std::span<const uint8_t> body, size_t n) {
  if (body.empty()) return err(ErrorCode::kTruncated, "region.fast", "body too short");
  FastBody fb;
  fb.shift = body[0];
  if (fb.shift > (sizeof(T) == 2 ? 15u : 0u))
    return err(ErrorCode::kCorrupt, "region.fast", "shift out of range");
  size_t at = 1;
  if (fb.shift > 0) {
    if (body.size() < 3) return err(ErrorCode::kTruncated, "region.fast", "body too short for the low bits");
    fb.low = get_u16(body.data() + 1);
    if (fb.low >= (1u << fb.shift)) return err(ErrorCode::kCorrupt, "region.fast", "low bits out of range");
    at = 3;
  }
  std::span<const uint8_t> rest = body.subspan(at);
  for (size_t p = 0; p < sizeof(T); ++p) {
    const char* field = p == 0 ? "region.fast.frame0" : "region.fast.frame1";
    size_t len = rest.size();
    if (p + 1 < sizeof(T)) {
      len = ZSTD_findFrameCompressedSize(rest.data(), rest.size());
      if (ZSTD_isError(len) || len > rest.size()) {
        return err(ErrorCode::kCorrupt, field, "no complete zstd frame");
      }
    }
    fb.frames[p] = rest.first(len);
    if (ZSTD_getFrameContentSize(fb.frames[p].data(), fb.frames[p].size()) != n) {
      return err(ErrorCode::kCorrupt, field, "zstd frame size does not match the rect");
    }
    rest = rest.subspan(len);
  }
  return fb;
}

template <typename T>
Status decode_fast(const FastBody& fb, uint32_t width, uint32_t height, std::span<T> out) {
  const size_t n = out.size();
  ZSTD_DCtx* dc = dctx();
  if (dc == nullptr) return err(ErrorCode::kCorrupt, "region.fast", "no zstd context");
  uint8_t* planes = grown(fast_scratch().planes, sizeof(T) * n);
  for (size_t p = 0; p < sizeof(T); ++p) {
    const size_t got = ZSTD_decompressDCtx(dc, planes + p * n, n, fb.frames[p].data(), fb.frames[p].size());
    if (ZSTD_isError(got) || got != n) {
      return err(ErrorCode::kCorrupt, p == 0 ? "region.fast.frame0" : "region.fast.frame1",
                 ZSTD_isError(got) ? ZSTD_getErrorName(got) : "zstd frame shorter than the plane");
    }
  }
  if constexpr (sizeof(T) == 2) {
    codec::med_inverse_u16({planes, n}, {planes + n, n}, width, height, out);
    if (fb.shift > 0)
      for (uint16_t& v : out) v = uint16_t((uint32_t(v) << fb.shift) | fb.low);
  } else {
    codec::med_inverse_i8({planes, n}, width, height, out);
  }
  return {};
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
  if (body.size() < kReductionSize) return err(ErrorCode::kTruncated, "region.reduction", "body too short");
  Reduction red;
  red.bits = body[0];
  red.g = get_u16(body.data() + 1);
  red.r = get_u16(body.data() + 3);
  if (red.bits < 1 || red.bits > max_bits || red.g < 1 || red.r >= red.g || red.g > max_u + 1) {
    return err(ErrorCode::kCorrupt, "region.reduction", "bits/step/offset out of range");
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

// Refinement. The rect's samples at even (x, y) are known (mip m). Pass A codes the odd
// columns of even rows against a horizontal cubic interpolation of their even neighbours;
// pass B codes every odd row against a vertical cubic interpolation of the (now complete)
// even rows. Each pass codes the field of interpolation residuals with the field coder,
// whose causal predictor then catches what interpolation misses (residuals are correlated
// along a ridge), with the interpolation's local slope and curvature steering contexts.
// `v` holds the reduced rect (values in [0, 2^bits)); on decode its even samples are
// filled and the rest is written.
template <typename Coder>
void code_refine(Coder& c, std::vector<int32_t>& v, uint32_t width, uint32_t height, int bits) {
  const int32_t lo = 0, hi = (int32_t(1) << bits) - 1;
  const codec::FieldShape residual_shape_bits{0, 0, bits + 1, -(int32_t(1) << bits)};
  const int64_t w = width, h = height;
  auto at = [&](int64_t x, int64_t y) -> int32_t& { return v[size_t(y * w + x)]; };
  // Clamps an even coordinate into [0, last even < n].
  auto even_clamp = [](int64_t i, int64_t n) {
    const int64_t last = (n - 1) & ~int64_t(1);
    return std::clamp<int64_t>(i, 0, last);
  };
  auto slope = [](int32_t a, int32_t b, int32_t cc, int32_t d) {
    return (std::abs(cc - b) + std::abs(a - 2 * b + cc) + std::abs(b - 2 * cc + d)) / 2;
  };

  // Pass A: (odd x, even y).
  const int64_t aw = w / 2, ah = (h + 1) / 2;
  if (aw > 0) {
    std::vector<int32_t> interp(size_t(aw * ah)), side(size_t(aw * ah)), r(size_t(aw * ah));
    for (int64_t j = 0; j < ah; ++j) {
      for (int64_t i = 0; i < aw; ++i) {
        const int64_t x = 2 * i + 1, y = 2 * j;
        const int32_t a = at(even_clamp(x - 3, w), y), b = at(x - 1, y), cc = at(even_clamp(x + 1, w), y),
                      d = at(even_clamp(x + 3, w), y);
        const size_t k = size_t(j * aw + i);
        interp[k] = codec::cubic_mid(a, b, cc, d, lo, hi);
        side[k] = slope(a, b, cc, d);
        if constexpr (!Coder::kDecoding) r[k] = at(x, y) - interp[k];
      }
    }
    codec::FieldShape fs = residual_shape_bits;
    fs.width = uint32_t(aw);
    fs.height = uint32_t(ah);
    if constexpr (Coder::kDecoding) {
      codec::decode_field(r, fs, c, side);
    } else {
      codec::encode_field(r, fs, c, side);
    }
    for (int64_t j = 0; j < ah; ++j)
      for (int64_t i = 0; i < aw; ++i) {
        const size_t k = size_t(j * aw + i);
        at(2 * i + 1, 2 * j) = (interp[k] + r[k]) & hi;
      }
  }
  // Pass B: every x of odd y.
  const int64_t bh = h / 2;
  if (bh > 0) {
    std::vector<int32_t> interp(size_t(w * bh)), side(size_t(w * bh)), r(size_t(w * bh));
    for (int64_t j = 0; j < bh; ++j) {
      const int64_t y = 2 * j + 1;
      const int64_t ya = even_clamp(y - 3, h), yb = y - 1, yc = even_clamp(y + 1, h),
                    yd = even_clamp(y + 3, h);
      for (int64_t x = 0; x < w; ++x) {
        const int32_t a = at(x, ya), b = at(x, yb), cc = at(x, yc), d = at(x, yd);
        const size_t k = size_t(j * w + x);
        interp[k] = codec::cubic_mid(a, b, cc, d, lo, hi);
        side[k] = slope(a, b, cc, d);
        if constexpr (!Coder::kDecoding) r[k] = at(x, y) - interp[k];
      }
    }
    codec::FieldShape fs = residual_shape_bits;
    fs.width = uint32_t(w);
    fs.height = uint32_t(bh);
    if constexpr (Coder::kDecoding) {
      codec::decode_field(r, fs, c, side);
    } else {
      codec::encode_field(r, fs, c, side);
    }
    for (int64_t j = 0; j < bh; ++j)
      for (int64_t x = 0; x < w; ++x) {
        const size_t k = size_t(j * w + x);
        at(x, 2 * j + 1) = (interp[k] + r[k]) & hi;
      }
  }
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
  code_refine(enc, f, width, height, red.bits);
  enc.finish();
  return with_header(RegionEncoding::kRefine, Traits<T>::kType, width, height, std::move(out));
}

template <typename T>
Result<std::vector<uint8_t>> encode_any(RegionEncoding encoding, std::span<const T> s, uint32_t width,
                                        uint32_t height, const RegionRefs<T>& refs) {
  LOAM_TRY(check_dims(width, height));
  const size_t n = size_t(width) * height;
  if (s.size() != n) {
    return err(ErrorCode::kInvalidArgument, "region.samples",
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
      if (refs.base.size() != n) return err(ErrorCode::kInvalidArgument, "region.base", "base size differs");
      out = encode_delta(s, refs.base, width, height);
      break;
    case RegionEncoding::kRefine: {
      const size_t cw = (width + 1) / 2, ch = (height + 1) / 2;
      if (refs.coarser.size() != cw * ch) {
        return err(ErrorCode::kInvalidArgument, "region.coarser", "coarser mip size differs");
      }
      for (size_t y = 0; y < ch; ++y)
        for (size_t x = 0; x < cw; ++x)
          if (refs.coarser[y * cw + x] != s[2 * y * width + 2 * x]) {
            return err(ErrorCode::kInvalidArgument, "region.coarser",
                       "coarser mip does not match the rect's even samples");
          }
      out = encode_refine(s, width, height);
      break;
    }
    default: return err(ErrorCode::kBadEnum, "region.encoding", "unknown encoding");
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
    return err(ErrorCode::kCorrupt, "region.type", "payload holds the other layer's sample type");
  }
  if (hd.width != width || hd.height != height) {
    return err(ErrorCode::kCorrupt, "region.size",
               "payload is " + std::to_string(hd.width) + "x" + std::to_string(hd.height) + ", rect is " +
                   std::to_string(width) + "x" + std::to_string(height));
  }
  const std::span<const uint8_t> body = payload.subspan(kRegionHeaderSize, hd.body_size);
  if (region_checksum(payload) != hd.body_checksum) {
    return err(ErrorCode::kCorrupt, "region.checksum", "body checksum mismatch");
  }
  const size_t n = size_t(width) * height;
  // References are checked before the output is allocated.
  if (hd.encoding == RegionEncoding::kDelta && refs.base.size() != n) {
    return err(ErrorCode::kInvalidArgument, "region.base",
               "delta needs the base rect (" + std::to_string(n) + " samples), got " +
                   std::to_string(refs.base.size()));
  }
  const size_t cw = (width + 1) / 2, ch = (height + 1) / 2;
  if (hd.encoding == RegionEncoding::kRefine && refs.coarser.size() != cw * ch) {
    return err(ErrorCode::kInvalidArgument, "region.coarser",
               "refinement needs the coarser mip (" + std::to_string(cw * ch) + " samples), got " +
                   std::to_string(refs.coarser.size()));
  }
  if (hd.encoding == RegionEncoding::kRaw && body.size() != n * sizeof(T)) {
    return err(
        ErrorCode::kCorrupt, "region.raw",
        "body holds " + std::to_string(body.size()) + " bytes, rect needs " + std::to_string(n * sizeof(T)));
  }
  FastBody fast;
  if (hd.encoding == RegionEncoding::kFast) {
    auto fb = parse_fast<T>(body, n);
    if (!fb) return fb.error();
    fast = *fb;
  }
  if (hd.encoding != RegionEncoding::kRaw && hd.encoding != RegionEncoding::kFast &&
      body.size() < kReductionSize + 5) {
    return err(ErrorCode::kTruncated, "region.stream", "range coder stream shorter than its 5-byte flush");
  }

  std::vector<T> out(n);
  switch (hd.encoding) {
    case RegionEncoding::kRaw:
      for (size_t i = 0; i < n; ++i) {
        if constexpr (sizeof(T) == 2) {
          out[i] = uint16_t(get_u16(body.data() + 2 * i));
        } else {
          out[i] = int8_t(body[i]);
        }
      }
      break;
    case RegionEncoding::kFast: LOAM_TRY(decode_fast<T>(fast, width, height, out)); break;
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
              return err(ErrorCode::kCorrupt, "region.coarser",
                         "coarser mip is off the payload's sample lattice");
            }
            f[2 * y * width + 2 * x] = int32_t((u - rd.r) / rd.g);
          }
        code_refine(dec, f, width, height, rd.bits);
      }
      if (dec.overran()) return err(ErrorCode::kTruncated, field, "stream ended before the last sample");
      if (dec.remaining() != 0) {
        return err(ErrorCode::kCorrupt, field,
                   std::to_string(dec.remaining()) + " bytes after the last sample");
      }
      for (size_t i = 0; i < n; ++i) {
        if (is_delta) {
          out[i] = wrap_sample<T>(int32_t(int64_t(refs.base[i]) + int64_t(f[i]) * rd.g));
        } else {
          const uint64_t u = uint64_t(uint32_t(f[i])) * rd.g + rd.r;
          if (u > max_u) return err(ErrorCode::kCorrupt, field, "sample outside the sample type's range");
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
      return err(ErrorCode::kCorrupt, "region.hash", "decoded samples do not match the hash");
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
    return err(
        ErrorCode::kTruncated, "region.header",
        std::to_string(payload.size()) + " bytes, the header needs " + std::to_string(kRegionHeaderSize));
  }
  const uint8_t* p = payload.data();
  if (p[0] != kMagic0 || p[1] != kMagic1)
    return err(ErrorCode::kCorrupt, "region.magic", "not a region payload");
  if (p[2] != kFormatVersion) {
    return err(ErrorCode::kUnsupported, "region.version", "format version " + std::to_string(p[2]));
  }
  if (p[3] >= kRegionEncodingCount) {
    return err(ErrorCode::kBadEnum, "region.encoding", "encoding " + std::to_string(p[3]));
  }
  if (p[4] > uint8_t(SampleType::kDetailI8)) {
    return err(ErrorCode::kBadEnum, "region.type", "sample type " + std::to_string(p[4]));
  }
  if (p[5] != 0) return err(ErrorCode::kUnsupported, "region.flags", "unknown flags " + std::to_string(p[5]));
  RegionHeader h;
  h.encoding = RegionEncoding(p[3]);
  h.type = SampleType(p[4]);
  h.width = get_u16(p + 6);
  h.height = get_u16(p + 8);
  h.body_size = get_u32(p + 10);
  h.body_checksum = get_u32(p + 14);
  LOAM_TRY(check_dims(h.width, h.height));
  if (h.body_size != payload.size() - kRegionHeaderSize) {
    return err(h.body_size > payload.size() - kRegionHeaderSize ? ErrorCode::kTruncated : ErrorCode::kCorrupt,
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
