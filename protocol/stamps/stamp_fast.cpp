#include "protocol/stamps/stamp_fast.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "protocol/stamps/stamp_validate.h"
#include "protocol/world.h"
#include "protocol/world_layers.h"

// The AVX2 kernel is compiled for AVX2 per function (target attribute) and chosen at run
// time, so the library still runs on any x86-64 and builds anywhere else without it.
#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define LOAM_STAMP_AVX2 1
#include <immintrin.h>
#define LOAM_TARGET_AVX2 __attribute__((target("avx2")))
#else
#define LOAM_STAMP_AVX2 0
#endif

namespace loam {

namespace {

using Op = FastStamp::Op;

// floor(sqrt(v)) for v < 2^52: sqrt is correctly rounded, and for such v the rounded root
// never reaches the next integer above a non-square, so truncation is the exact floor (the
// same argument as isqrt32, which adds checks that never fire).
inline uint32_t isqrt_exact(uint64_t v) { return uint32_t(std::sqrt(double(v))); }

// |reduce(d, s)|: reduction truncates toward zero, so its magnitude is |d| >> s.
inline int32_t reduced_abs(int64_t d_q8, int32_t s) { return int32_t((d_q8 < 0 ? -d_q8 : d_q8) >> s); }

// The columns of one row inside the disc: x with isqrt(a(x)² + b²) < Rr, a(x) = |x·256 − cx| >> s.
// isqrt(v) < Rr ⇔ v < Rr², so a² < lim = Rr² − b², i.e. a <= m = isqrt(lim − 1), i.e.
// |x·256 − cx| <= D = ((m + 1) << s) − 1. Returns [x0, x1) clipped to `clip` (may be empty).
struct Span {
  int64_t x0 = 0, x1 = 0;
};
Span disc_row_span(const BakedStamp& b, int64_t b_abs, int64_t clip_x0, int64_t clip_x1) {
  const int64_t rr = b.radius_r;
  const int64_t lim = rr * rr - b_abs * b_abs;
  if (lim <= 0) return {};
  const int64_t m = isqrt_exact(uint64_t(lim - 1));
  const int64_t d = ((m + 1) << b.shift) - 1;
  return {std::max(clip_x0, ceil_div(b.q.center_x - d, 256)),
          std::min(clip_x1, floor_div(b.q.center_x + d, 256) + 1)};
}

// The per-sample combination, exactly as stamp_sample writes it per kind (see value_at_dist
// for what v holds).
template <Op op>
inline int32_t combine(int32_t old, int32_t v, int32_t lo, int32_t hi, int32_t target) {
  if constexpr (op == Op::kAddSat) return std::clamp(old + v, lo, hi);
  if constexpr (op == Op::kMin) return std::min(old, v);
  if constexpr (op == Op::kMax) return std::max(old, v);
  if constexpr (op == Op::kFlatten) return old + (((target - old) * v + 8192) >> 14);
  return old;
}

// Tracks the first and last changed sample of a row (indices relative to the row start).
struct RowChange {
  int32_t first = -1, last = -1;
  void add(int32_t i) {
    if (first < 0) first = i;
    last = i;
  }
};

// What a radial row kernel needs, gathered once per stamp.
struct RowArgs {
  const int32_t* by_dist;  // nullptr: compute per sample through the stamp
  int32_t shift, lo, hi, target;
  int32_t radius_r;  // by_dist[radius_r] leaves a sample unchanged (vector rows past the disc)
  // Vector rows without by_dist: the profile table, u = (dist << 16) / Rr as m and k, and
  // value_at_dist_u's affine form (FastStamp::ValueForm).
  const int32_t* table;
  uint32_t div_m, div_k;
  int32_t base, sign, offset, vlo, vhi, neutral;
  bool raw;
};

// Portable row kernel: samples row[0..n) whose offsets are d0 + 256 i (Q8), |dyr| = b_abs.
template <typename T, Op op, typename ValueFn>
void radial_row_portable(const RowArgs& a, const ValueFn& value, T* row, int64_t d0, int32_t n, int32_t b_abs,
                         RowChange& ch) {
  const uint32_t b2 = uint32_t(b_abs) * uint32_t(b_abs);
  for (int32_t i = 0; i < n; ++i) {
    const uint32_t ar = uint32_t(reduced_abs(d0 + int64_t(i) * 256, a.shift));
    const int32_t dist = int32_t(isqrt_exact(ar * ar + b2));
    const int32_t old = row[i];
    // Rows padded for the vector kernel reach past the disc (dist >= Rr): entry Rr keeps them.
    const int32_t v = a.by_dist != nullptr ? a.by_dist[std::min(dist, a.radius_r)] : value(dist);
    const int32_t nv = combine<op>(old, v, a.lo, a.hi, a.target);
    if (nv != old) {
      row[i] = T(nv);
      ch.add(i);
    }
  }
}

#if LOAM_STAMP_AVX2

template <typename T>
LOAM_TARGET_AVX2 inline __m256i load8(const T* p) {
  if constexpr (sizeof(T) == 2) {
    return _mm256_cvtepu16_epi32(_mm_loadu_si128(reinterpret_cast<const __m128i*>(p)));
  } else {
    return _mm256_cvtepi8_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(p)));
  }
}

// Values are already inside the layer range (every op keeps them there), so the saturating
// packs are plain narrowing here.
template <typename T>
LOAM_TARGET_AVX2 inline void store8(T* p, __m256i v) {
  const __m128i lo = _mm256_castsi256_si128(v), hi = _mm256_extracti128_si256(v, 1);
  if constexpr (sizeof(T) == 2) {
    _mm_storeu_si128(reinterpret_cast<__m128i*>(p), _mm_packus_epi32(lo, hi));
  } else {
    const __m128i w = _mm_packs_epi32(lo, hi);
    _mm_storel_epi64(reinterpret_cast<__m128i*>(p), _mm_packs_epi16(w, w));
  }
}

template <Op op>
LOAM_TARGET_AVX2 inline __m256i combine8(__m256i old, __m256i v, __m256i lo, __m256i hi, __m256i target) {
  if constexpr (op == Op::kAddSat)
    return _mm256_min_epi32(_mm256_max_epi32(_mm256_add_epi32(old, v), lo), hi);
  if constexpr (op == Op::kMin) return _mm256_min_epi32(old, v);
  if constexpr (op == Op::kMax) return _mm256_max_epi32(old, v);
  if constexpr (op == Op::kFlatten) {
    // |target − old| < 2^16 and v <= 2^14: the product fits int32; srai is the floor shift.
    const __m256i p = _mm256_mullo_epi32(_mm256_sub_epi32(target, old), v);
    return _mm256_add_epi32(old, _mm256_srai_epi32(_mm256_add_epi32(p, _mm256_set1_epi32(8192)), 14));
  }
  return old;
}

// isqrt of eight d2 < 2^29. float(d2) is within 2^-24 relative of d2 and sqrtps is correctly
// rounded, so the float root is within 0.002 of the real root (< 23171) and its truncation r
// within one of isqrt(d2). r and r + 1 are below 2^15, so madd (r as the low int16 of its lane,
// 0 above) gives their exact squares, and isqrt = r + 1 + [r² > d2 ? −1 : 0] +
// [(r + 1)² > d2 ? −1 : 0]. (rsqrt with a Newton step measured slower here.)
LOAM_TARGET_AVX2 inline __m256i isqrt8(__m256i d2, __m256i one) {
  const __m256i r = _mm256_cvttps_epi32(_mm256_sqrt_ps(_mm256_cvtepi32_ps(d2)));
  const __m256i r1 = _mm256_add_epi32(r, one);
  const __m256i over0 = _mm256_cmpgt_epi32(_mm256_madd_epi16(r, r), d2);
  const __m256i over1 = _mm256_cmpgt_epi32(_mm256_madd_epi16(r1, r1), d2);
  return _mm256_add_epi32(_mm256_add_epi32(r1, over0), over1);
}

LOAM_TARGET_AVX2 void isqrt_avx2(const uint32_t* in, uint32_t* out, size_t n) {
  const __m256i one = _mm256_set1_epi32(1);
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    const __m256i v = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(in + i));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + i), isqrt8(v, one));
  }
  for (; i < n; ++i) out[i] = isqrt_exact(in[i]);
}

// The smallest and the largest of eight lanes.
LOAM_TARGET_AVX2 inline int32_t hmin8(__m256i v) {
  __m128i m = _mm_min_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
  m = _mm_min_epi32(m, _mm_shuffle_epi32(m, 0x4E));
  return _mm_cvtsi128_si32(_mm_min_epi32(m, _mm_shuffle_epi32(m, 0xB1)));
}
LOAM_TARGET_AVX2 inline int32_t hmax8(__m256i v) {
  __m128i m = _mm_max_epi32(_mm256_castsi256_si128(v), _mm256_extracti128_si256(v, 1));
  m = _mm_max_epi32(m, _mm_shuffle_epi32(m, 0x4E));
  return _mm_cvtsi128_si32(_mm_max_epi32(m, _mm_shuffle_epi32(m, 0xB1)));
}

// value_at_dist_u of eight dists straight from the profile table, for stamps smaller than their
// per-dist table would be. dist is clamped to Rr, so u <= 65536 and both table indices stay in
// [0, 1024]; lanes at dist >= Rr (rows padded past the disc) take the neutral value.
// u = (dist << 16) · m >> k (ExactDivisor: dist << 16 < 2^30, m < 2^32) on the even and odd
// lanes' 64-bit products; then table_lookup and round_q8 as the scalar code writes them.
LOAM_TARGET_AVX2 inline __m256i value8_direct(const RowArgs& a, __m256i dist) {
  const __m256i rr = _mm256_set1_epi32(a.radius_r);
  const __m256i inside = _mm256_cmpgt_epi32(rr, dist);
  const __m256i n = _mm256_slli_epi32(_mm256_min_epi32(dist, rr), 16);
  const __m256i m = _mm256_set1_epi64x(int64_t(a.div_m));
  const __m128i k = _mm_cvtsi32_si128(int32_t(a.div_k));
  const __m256i even = _mm256_srl_epi64(_mm256_mul_epu32(n, m), k);
  const __m256i odd =
      _mm256_slli_epi64(_mm256_srl_epi64(_mm256_mul_epu32(_mm256_srli_epi64(n, 32), m), k), 32);
  const __m256i u = _mm256_blend_epi32(even, odd, 0xAA);
  const __m256i i = _mm256_srli_epi32(u, kProfileFracBits);
  const __m256i f = _mm256_and_si256(u, _mm256_set1_epi32((1 << kProfileFracBits) - 1));
  const __m256i t0 = _mm256_i32gather_epi32(a.table, i, 4);
  const __m256i i1 =
      _mm256_min_epi32(_mm256_add_epi32(i, _mm256_set1_epi32(1)), _mm256_set1_epi32(kProfileEntries));
  const __m256i t1 = _mm256_i32gather_epi32(a.table, i1, 4);
  const __m256i t = _mm256_add_epi32(
      t0, _mm256_srai_epi32(_mm256_mullo_epi32(_mm256_sub_epi32(t1, t0), f), kProfileFracBits));
  __m256i v = t;
  if (!a.raw) {
    const __m256i r = _mm256_srai_epi32(_mm256_add_epi32(t, _mm256_set1_epi32(a.base + 128)), 8);
    v = _mm256_add_epi32(_mm256_sign_epi32(r, _mm256_set1_epi32(a.sign)), _mm256_set1_epi32(a.offset));
    v = _mm256_min_epi32(_mm256_max_epi32(v, _mm256_set1_epi32(a.vlo)), _mm256_set1_epi32(a.vhi));
  }
  return _mm256_blendv_epi8(_mm256_set1_epi32(a.neutral), v, inside);
}

// AVX2 row kernel, eight samples at a time, with the value per dist from by_dist (kDirect
// false) or from the profile table (value8_direct). Per lane, a = |d| >> s (< 2^14 inside the
// rect) and b share one 32-bit lane as two int16, so madd gives d2 = a² + b² (< 2^29) exactly;
// see isqrt8. n is a multiple of 8: the caller pads rows to whole vectors with the tile row's
// samples past the disc, whose dist (>= Rr) gets the value that leaves the old one as it is.
// The first and last changed sample are tracked as vector minima and maxima of the lane index
// (no per-vector branch).
template <typename T, Op op, bool kDirect>
LOAM_TARGET_AVX2 void radial_row_avx2(const RowArgs& a, T* row, int64_t d0, int32_t n, int32_t b_abs,
                                      RowChange& ch) {
  const __m256i lane = _mm256_setr_epi32(0, 256, 512, 768, 1024, 1280, 1536, 1792);
  __m256i d = _mm256_add_epi32(_mm256_set1_epi32(int32_t(d0)), lane);  // |d| < 2^25 in the rect
  const __m256i step = _mm256_set1_epi32(8 * 256);
  const __m128i shift = _mm_cvtsi32_si128(a.shift);
  const __m256i b_hi = _mm256_set1_epi32(b_abs << 16);
  const __m256i one = _mm256_set1_epi32(1);
  const __m256i outside = _mm256_set1_epi32(a.radius_r);
  const __m256i lo = _mm256_set1_epi32(a.lo), hi = _mm256_set1_epi32(a.hi),
                target = _mm256_set1_epi32(a.target);
  __m256i index = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i eight = _mm256_set1_epi32(8);
  const __m256i none_first = _mm256_set1_epi32(INT32_MAX), none_last = _mm256_set1_epi32(-1);
  __m256i first = none_first, last = none_last;
  for (int32_t i = 0; i < n; i += 8) {
    // Lanes of the padding past the rect may have offsets beyond 2^14: clamped to Rr, they
    // stay outside the disc and d2 stays below 2^29.
    const __m256i a_abs = _mm256_min_epi32(_mm256_srl_epi32(_mm256_abs_epi32(d), shift), outside);
    const __m256i ab = _mm256_or_si256(a_abs, b_hi);
    const __m256i d2 = _mm256_madd_epi16(ab, ab);
    __m256i v;
    if constexpr (kDirect) {
      v = value8_direct(a, isqrt8(d2, one));
    } else {
      v = _mm256_i32gather_epi32(a.by_dist, _mm256_min_epi32(isqrt8(d2, one), outside), 4);
    }
    const __m256i old = load8(row + i);
    const __m256i nv = combine8<op>(old, v, lo, hi, target);
    store8(row + i, nv);
    const __m256i same = _mm256_cmpeq_epi32(nv, old);
    first = _mm256_min_epi32(first, _mm256_blendv_epi8(index, none_first, same));
    last = _mm256_max_epi32(last, _mm256_blendv_epi8(index, none_last, same));
    index = _mm256_add_epi32(index, eight);
    d = _mm256_add_epi32(d, step);
  }
  if (const int32_t l = hmax8(last); l >= 0) {
    ch.first = hmin8(first);
    ch.last = l;
  }
}

// The footprint's contact max(old · 256 − sole(dist)) over one row's disc span, eight samples
// at a time: the n samples from `row` (a multiple of 8, padded with the tile row's samples
// around the span) count only from lane `lead` for `count` lanes. The sole comes from the
// per-dist table `sole` where there is one (gathered), else from the profile table. Padded
// lanes' reduced offsets are clamped to Rr, so d2 stays below 2^29.
template <typename T>
LOAM_TARGET_AVX2 int32_t contact_row_avx2(const RowArgs& a, const int32_t* sole, const T* row, int64_t d0,
                                          int32_t n, int32_t lead, int32_t count, int32_t b_abs) {
  const __m256i lane = _mm256_setr_epi32(0, 256, 512, 768, 1024, 1280, 1536, 1792);
  __m256i d = _mm256_add_epi32(_mm256_set1_epi32(int32_t(d0)), lane);
  const __m256i step = _mm256_set1_epi32(8 * 256);
  const __m128i shift = _mm_cvtsi32_si128(a.shift);
  const __m256i b_hi = _mm256_set1_epi32(b_abs << 16);
  const __m256i one = _mm256_set1_epi32(1);
  const __m256i rr = _mm256_set1_epi32(a.radius_r);
  const __m256i none = _mm256_set1_epi32(INT32_MIN);
  const __m256i from = _mm256_set1_epi32(lead - 1), to = _mm256_set1_epi32(lead + count);
  __m256i index = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i eight = _mm256_set1_epi32(8);
  __m256i best = none;
  for (int32_t i = 0; i < n; i += 8) {
    const __m256i a_abs = _mm256_min_epi32(_mm256_srl_epi32(_mm256_abs_epi32(d), shift), rr);
    const __m256i ab = _mm256_or_si256(a_abs, b_hi);
    const __m256i dist = _mm256_min_epi32(isqrt8(_mm256_madd_epi16(ab, ab), one), rr);
    const __m256i s = sole != nullptr ? _mm256_i32gather_epi32(sole, dist, 4) : value8_direct(a, dist);
    const __m256i c = _mm256_sub_epi32(_mm256_slli_epi32(load8(row + i), 8), s);
    const __m256i valid = _mm256_and_si256(_mm256_cmpgt_epi32(index, from), _mm256_cmpgt_epi32(to, index));
    best = _mm256_max_epi32(best, _mm256_blendv_epi8(none, c, valid));
    index = _mm256_add_epi32(index, eight);
    d = _mm256_add_epi32(d, step);
  }
  return hmax8(best);
}

bool cpu_has_avx2() {
  static const bool has = __builtin_cpu_supports("avx2") != 0;
  return has;
}

#endif  // LOAM_STAMP_AVX2

}  // namespace

ExactDivisor::ExactDivisor(uint32_t d) {
  uint32_t l = 0;  // ceil(log2 d)
  while ((uint64_t(1) << l) < d) ++l;
  k = 30 + l;
  m = ((uint64_t(1) << k) + d - 1) / d;
}

bool fast_isa_available(FastIsa isa) {
#if LOAM_STAMP_AVX2
  if (isa == FastIsa::kAvx2 || isa == FastIsa::kAvx2Direct) return cpu_has_avx2();
#else
  if (isa == FastIsa::kAvx2 || isa == FastIsa::kAvx2Direct) return false;
#endif
  return true;
}

void fast_isqrt_for_test(std::span<const uint32_t> in, std::span<uint32_t> out, FastIsa isa) {
  const size_t n = std::min(in.size(), out.size());
#if LOAM_STAMP_AVX2
  if (isa != FastIsa::kPortable && cpu_has_avx2()) return isqrt_avx2(in.data(), out.data(), n);
#else
  (void)isa;
#endif
  for (size_t i = 0; i < n; ++i) out[i] = isqrt_exact(in[i]);
}

FastStamp::FastStamp(const BakedStamp& b, FastIsa isa) : b_(b), per_rr_(uint32_t(b.radius_r)) {
  const QuantizedStamp& q = b.q;
  lo_ = layer_min(q.layer);
  hi_ = layer_max(q.layer);
  switch (q.blend) {
    case BlendMode::kAdd:
    case BlendMode::kSubtract: op_ = Op::kAddSat; break;
    case BlendMode::kMin: op_ = Op::kMin; break;
    case BlendMode::kMax: op_ = Op::kMax; break;
  }
  if (q.kind == StampKind::kFootprint) op_ = b.has_contact ? Op::kMin : Op::kNone;
  if (q.kind == StampKind::kFlatten) op_ = Op::kFlatten;
  if (q.kind == StampKind::kShockwave) op_ = Op::kNone;
  if (op_ == Op::kNone || b.rect.empty()) return;
#if LOAM_STAMP_AVX2
  avx2_ = (isa == FastIsa::kBest || isa == FastIsa::kAvx2 || isa == FastIsa::kAvx2Direct) && cpu_has_avx2();
#else
  (void)isa;
#endif
  // What the old value is combined with, from the profile table's t (value_of).
  form_.neutral = op_ == Op::kMin ? hi_ : op_ == Op::kMax ? lo_ : 0;
  form_.vlo = INT32_MIN;
  form_.vhi = INT32_MAX;
  if (q.kind == StampKind::kFlatten) {
    form_.raw = true;
  } else if (q.kind == StampKind::kFootprint) {
    form_.base = b.contact_q8 - q.intensity;
    form_.vlo = lo_;
    form_.vhi = hi_;
  } else if (q.blend == BlendMode::kSubtract) {
    form_.sign = -1;
  } else if (q.blend == BlendMode::kMin || q.blend == BlendMode::kMax) {
    form_.offset = q.target;
    form_.vlo = lo_;
    form_.vhi = hi_;
  }
  const int32_t rr = b.radius_r;
  const bool force_tables = isa == FastIsa::kPortable || isa == FastIsa::kAvx2;
  if (q.kind == StampKind::kTexture) {
    // Per-axis tables cost 2·(2Rr − 1) entries: worth it once the rect has more samples.
    if (b.rect.area() < 4 * int64_t(rr) && !force_tables) return;
    const StampTexture& t = *b.texture;
    auto build = [&](std::vector<Axis>& axis, int32_t size) {
      axis.resize(size_t(2 * rr - 1));
      const int32_t den = 4 * rr;  // as texture_value: position n / den, pixel centers at k + 1/2
      for (int32_t k = 0; k < 2 * rr - 1; ++k) {
        const int32_t ur = k - rr + 1;
        const int32_t nx = (ur + rr) * 2 * size - 2 * rr;
        const int32_t ix = int32_t(floor_div(nx, den));
        axis[size_t(k)] = {std::clamp(ix, 0, size - 1), std::clamp(ix + 1, 0, size - 1),
                           uint32_t(((nx - ix * den) << 8) / den)};
      }
    };
    build(tex_x_, t.width);
    build(tex_y_, t.height);
    return;
  }
  // Row spans depend on the row only; tiles clip them.
  rows_.resize(size_t(b.rect.height()));
  for (int64_t y = b.rect.y0; y < b.rect.y1; ++y) {
    const int32_t b_abs = reduced_abs(y * 256 - q.center_y, b.shift);
    const Span span = disc_row_span(b, b_abs, b.rect.x0, b.rect.x1);
    rows_[size_t(y - b.rect.y0)] = {span.x0, span.x1, b_abs};
  }
  // The per-dist table pays for itself once the rect has as many samples as it has entries
  // (portable rows), or sixteen times as many (AVX2 rows, whose value from the profile table
  // costs a second gather and a few arithmetic steps per eight samples).
  // u(dist) = floor(dist·65536 / Rr) is stepped exactly with a remainder, not divided.
  const int64_t pays = avx2_ ? 16 * int64_t(rr) : int64_t(rr);
  if ((b.rect.area() < pays && !force_tables) || isa == FastIsa::kAvx2Direct) return;
  by_dist_.resize(size_t(rr) + 1);
  const uint32_t step = uint32_t(kUnitQ16) / uint32_t(rr), rem = uint32_t(kUnitQ16) % uint32_t(rr);
  uint32_t u = 0, acc = 0;
  for (int32_t dist = 0; dist < rr; ++dist) {
    by_dist_[size_t(dist)] = value_at_dist_u(int32_t(u));
    u += step;
    acc += rem;
    if (acc >= uint32_t(rr)) {
      ++u;
      acc -= uint32_t(rr);
    }
  }
  // Past the disc: the value that leaves every old value unchanged under op_ (old values
  // are inside the layer range).
  by_dist_[size_t(rr)] = form_.neutral;
}

int32_t FastStamp::value_at_dist(int32_t dist) const {
  return value_at_dist_u(int32_t(per_rr_.divide(uint32_t(dist) << 16)));
}

int32_t FastStamp::value_at_dist_u(int32_t u) const { return value_of(table_lookup(b_.table, u)); }

// stamp_sample's per-kind step from the table value t to what is combined with the old value:
// round_q8 and the blend's sign, target and saturation, the footprint's contact, or flatten's
// weight itself (ValueForm; value8_direct computes the same on eight lanes).
int32_t FastStamp::value_of(int32_t t) const {
  if (form_.raw) return t;
  return std::clamp(form_.sign * ((t + form_.base + 128) >> 8) + form_.offset, form_.vlo, form_.vhi);
}

template <typename T>
RectI FastStamp::apply_radial(T* tile, int64_t tx, int64_t ty) const {
  const RectI part = b_.rect.intersect(tile_rect(int32_t(tx), int32_t(ty)));
  if (part.empty()) return {};
  const RowArgs args{by_dist_.empty() ? nullptr : by_dist_.data(),
                     b_.shift,
                     lo_,
                     hi_,
                     b_.q.target,
                     b_.radius_r,
                     b_.table.data(),
                     uint32_t(per_rr_.m),
                     per_rr_.k,
                     form_.base,
                     form_.sign,
                     form_.offset,
                     form_.vlo,
                     form_.vhi,
                     form_.neutral,
                     form_.raw};
  const bool vector_rows = avx2_;
  const bool direct = by_dist_.empty();
  auto value = [this](int32_t dist) { return value_at_dist(dist); };
  RectI changed;
  for (int64_t y = part.y0; y < part.y1; ++y) {
    Span span;
    int32_t b_abs = 0;
    if (rows_.empty()) {
      b_abs = reduced_abs(y * 256 - b_.q.center_y, b_.shift);
      span = disc_row_span(b_, b_abs, part.x0, part.x1);
    } else {
      const RowSpan& rs = rows_[size_t(y - b_.rect.y0)];
      b_abs = rs.b_abs;
      span = {std::max(rs.x0, part.x0), std::min(rs.x1, part.x1)};
    }
    if (span.x1 <= span.x0) continue;
    if (vector_rows) {
      // Whole vectors: pad with the tile row's samples past the disc, right first, then left
      // (a tile row is 256 samples, so no remainder is left). Past the disc they keep their
      // values, past the rect too: the kernel clamps their reduced offset to Rr.
      const int64_t want = (span.x1 - span.x0 + 7) & ~int64_t(7);
      span.x1 = std::min(tx * kTileSize + kTileSize, span.x0 + want);
      span.x0 = std::max(tx * kTileSize, span.x1 - want);
    }
    T* row = tile + (y - ty * kTileSize) * kTileSize + (span.x0 - tx * kTileSize);
    const int64_t d0 = span.x0 * 256 - b_.q.center_x;
    const int32_t n = int32_t(span.x1 - span.x0);
    RowChange ch;
    auto run = [&]<Op op>() {
#if LOAM_STAMP_AVX2
      if (vector_rows && direct) return radial_row_avx2<T, op, true>(args, row, d0, n, b_abs, ch);
      if (vector_rows) return radial_row_avx2<T, op, false>(args, row, d0, n, b_abs, ch);
#endif
      radial_row_portable<T, op>(args, value, row, d0, n, b_abs, ch);
    };
    switch (op_) {
      case Op::kAddSat: run.template operator()<Op::kAddSat>(); break;
      case Op::kMin: run.template operator()<Op::kMin>(); break;
      case Op::kMax: run.template operator()<Op::kMax>(); break;
      case Op::kFlatten: run.template operator()<Op::kFlatten>(); break;
      case Op::kNone: break;
    }
    if (ch.first >= 0) changed = changed.unite(RectI{span.x0 + ch.first, y, span.x0 + ch.last + 1, y + 1});
  }
  return changed;
}

template <typename T>
RectI FastStamp::apply_texture(T* tile, int64_t tx, int64_t ty) const {
  const RectI part = b_.rect.intersect(tile_rect(int32_t(tx), int32_t(ty)));
  RectI changed;
  const QuantizedStamp& q = b_.q;
  const int32_t rr = b_.radius_r, cs = b_.cos_q15, sn = b_.sin_q15;
  const StampTexture& tex = *b_.texture;
  for (int64_t y = part.y0; y < part.y1; ++y) {
    T* row = tile + (y - ty * kTileSize) * kTileSize - tx * kTileSize;
    RowChange ch;
    if (tex_x_.empty()) {
      // Small stamp: the tables would cost more than they save; the reference kernel itself.
      for (int64_t x = part.x0; x < part.x1; ++x) {
        const int32_t old = row[x];
        const int32_t nv = stamp_sample(b_, x, y, old);
        if (nv != old) {
          row[x] = T(nv);
          ch.add(int32_t(x - part.x0));
        }
      }
    } else {
      // stamp_sample's texture branch with the per-row products hoisted and the image
      // position, clamped indices and weights of each axis read from the tables.
      const int32_t dy = reduce(y * 256 - q.center_y, b_.shift);
      const int32_t dy_sin = dy * sn, dy_cos = dy * cs;
      for (int64_t x = part.x0; x < part.x1; ++x) {
        const int32_t dx = reduce(x * 256 - q.center_x, b_.shift);
        const int32_t ur = (dx * cs + dy_sin) >> 15;
        const int32_t vr = (dy_cos - dx * sn) >> 15;
        if (ur <= -rr || ur >= rr || vr <= -rr || vr >= rr) continue;
        const Axis& ax = tex_x_[size_t(ur + rr - 1)];
        const Axis& ay = tex_y_[size_t(vr + rr - 1)];
        const uint16_t* row0 = tex.samples.data() + size_t(ay.i0) * size_t(tex.width);
        const uint16_t* row1 = tex.samples.data() + size_t(ay.i1) * size_t(tex.width);
        const uint32_t top = row0[ax.i0] * (256u - ax.f) + row0[ax.i1] * ax.f;
        const uint32_t bot = row1[ax.i0] * (256u - ax.f) + row1[ax.i1] * ax.f;
        const uint32_t t = (top * (256u - ay.f) + bot * ay.f + 32768u) >> 16;
        const int32_t u = int32_t(t + (t >> 15));
        const int32_t v = value_of(table_lookup(b_.table, u));
        const int32_t old = row[x];
        int32_t nv = old;
        switch (op_) {
          case Op::kAddSat: nv = combine<Op::kAddSat>(old, v, lo_, hi_, 0); break;
          case Op::kMin: nv = combine<Op::kMin>(old, v, lo_, hi_, 0); break;
          case Op::kMax: nv = combine<Op::kMax>(old, v, lo_, hi_, 0); break;
          default: break;
        }
        if (nv != old) {
          row[x] = T(nv);
          ch.add(int32_t(x - part.x0));
        }
      }
    }
    if (ch.first >= 0) changed = changed.unite(RectI{part.x0 + ch.first, y, part.x0 + ch.last + 1, y + 1});
  }
  return changed;
}

RectI FastStamp::apply_in_tile(uint16_t* tile, int64_t tx, int64_t ty) const {
  if (op_ == Op::kNone) return {};
  return b_.q.kind == StampKind::kTexture ? apply_texture(tile, tx, ty) : apply_radial(tile, tx, ty);
}

RectI FastStamp::apply_in_tile(int8_t* tile, int64_t tx, int64_t ty) const {
  if (op_ == Op::kNone) return {};
  return b_.q.kind == StampKind::kTexture ? apply_texture(tile, tx, ty) : apply_radial(tile, tx, ty);
}

void footprint_contact_fast(BakedStamp& b, const World& world) {
  b.has_contact = false;
  b.contact_q8 = 0;
  if (b.rect.empty()) return;
  const int32_t rr = b.radius_r;
  const ExactDivisor per_rr{uint32_t(rr)};
  auto sole_at = [&](int32_t dist) {
    return table_lookup(b.table, int32_t(per_rr.divide(uint32_t(dist) << 16)));
  };
#if LOAM_STAMP_AVX2
  const bool avx2 = cpu_has_avx2();
  RowArgs args{};
  args.shift = b.shift;
  args.radius_r = rr;
  args.table = b.table.data();
  args.div_m = uint32_t(per_rr.m);
  args.div_k = per_rr.k;
  args.raw = true;  // the sole height itself
  // Large feet: the sole per dist, gathered (as the stamp's own per-dist table, when the rect
  // has 16 samples per entry).
  std::vector<int32_t> sole;
  if (avx2 && b.rect.area() >= 16 * int64_t(rr)) {
    sole.resize(size_t(rr) + 1);
    for (int32_t dist = 0; dist <= rr; ++dist) sole[size_t(dist)] = sole_at(std::min(dist, rr - 1));
  }
#endif
  int32_t best = INT32_MIN;
  bool any = false;
  const RectI tiles = tiles_overlapping(b.rect);
  visit_layer(b.q.layer, [&](auto layer_row) {
    using R = decltype(layer_row);
    for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
      for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
        const RectI part = b.rect.intersect(tile_rect(int32_t(tx), int32_t(ty)));
        // A layer with a base has every tile (empty: outside the world); without one, an
        // unstored tile is all zero.
        const auto tile = LayerOps<R>::tile(world, int32_t(tx), int32_t(ty));
        if (R::kHasBase && tile.empty()) continue;
        for (int64_t y = part.y0; y < part.y1; ++y) {
          const int32_t b_abs = reduced_abs(y * 256 - b.q.center_y, b.shift);
          const Span span = disc_row_span(b, b_abs, part.x0, part.x1);
          if (span.x1 <= span.x0) continue;
          any = true;
          const size_t base = size_t((y - ty * kTileSize) * kTileSize - tx * kTileSize);
          int64_t x = span.x0;
#if LOAM_STAMP_AVX2
          if (avx2 && !tile.empty()) {
            // Whole vectors over the span, padded with the tile row (as the stamp's rows are).
            const int64_t want = (span.x1 - span.x0 + 7) & ~int64_t(7);
            const int64_t x1 = std::min(tx * kTileSize + kTileSize, span.x0 + want);
            const int64_t x0 = std::max(tx * kTileSize, x1 - want);
            best = std::max(best, contact_row_avx2(args, sole.empty() ? nullptr : sole.data(),
                                                   tile.data() + (base + size_t(x0)), x0 * 256 - b.q.center_x,
                                                   int32_t(x1 - x0), int32_t(span.x0 - x0),
                                                   int32_t(span.x1 - span.x0), b_abs));
            x = span.x1;
          }
#endif
          for (; x < span.x1; ++x) {
            const uint32_t ar = uint32_t(reduced_abs(x * 256 - b.q.center_x, b.shift));
            const int32_t dist = int32_t(isqrt_exact(uint64_t(ar) * ar + uint64_t(b_abs) * uint64_t(b_abs)));
            const int32_t old = tile.empty() ? 0 : int32_t(tile[base + size_t(x)]);
            best = std::max(best, old * 256 - sole_at(dist));
          }
        }
      }
    }
  });
  b.has_contact = any;
  b.contact_q8 = any ? best : 0;
}

}  // namespace loam
