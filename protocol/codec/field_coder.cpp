#include "protocol/codec/field_coder.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstdlib>
#include <memory>
#include <vector>

namespace loam::codec {
namespace {

// Candidate predictors blended per sample. Terrain is smooth at most scales, so besides the
// neighbours themselves the planes and linear extrapolations carry most of the weight.
constexpr int kCandidates = 8;
constexpr int kStride = kCandidates + kMaxExtraCandidates;  // candidate slots per sample
constexpr int kActivityBuckets = 24;
constexpr int kBiasBuckets = 8;
constexpr int kFracBits = 3;  // fixed-point bits of the blended prediction

// Quantizes an error energy into a context index, roughly logarithmic (two buckets per
// octave above 4) so that contexts see similar residual scales.
inline int activity_bucket(uint32_t a) {
  if (a < 4) return int(a);
  const int b = std::bit_width(a);  // >= 3
  const int idx = 4 + (b - 3) * 2 + int((a >> (b - 2)) & 1u);
  return std::min(idx, kActivityBuckets - 1);
}

inline int64_t floor_div_pos(int64_t a, int64_t b) {  // b > 0
  const int64_t q = a / b;
  return (a % b != 0 && a < 0) ? q - 1 : q;
}

struct Model {
  std::array<BitModel, kActivityBuckets> zero{};
  std::array<std::array<BitModel, 9>, kActivityBuckets> sign{};
  std::array<std::array<BitModel, 17>, kActivityBuckets> expo{};
  std::array<std::array<std::array<BitModel, 4>, 17>, kActivityBuckets> mant{};
  std::array<int32_t, 64 * kBiasBuckets> bias_sum{};
  std::array<int32_t, 64 * kBiasBuckets> bias_count{};
};

inline int sign3(int32_t e) { return e < 0 ? 0 : (e == 0 ? 1 : 2); }

// Codes one residual e (|e| <= 2^(bits-1)) in context `ctx`; returns it (decoded or as given).
template <typename Coder>
inline int32_t code_residual(Coder& c, Model& m, int ctx, int sctx, int bits, int32_t e) {
  const int nz = c.bit(m.zero[ctx], e != 0);
  if (!nz) return 0;
  const int neg = c.bit(m.sign[ctx][sctx], e < 0);
  const uint32_t mag = uint32_t(e < 0 ? -e : e);
  const int k_in = Coder::kDecoding ? 0 : std::bit_width(mag) - 1;
  int k = 0;
  while (k < bits - 1 && c.bit(m.expo[ctx][k], k_in > k)) ++k;
  uint32_t value = 1;
  for (int j = k - 1; j >= 0; --j) {
    const int in = int((mag >> j) & 1u);
    int b;
    if (k - 1 - j < 2) {
      b = c.bit(m.mant[ctx][k][value], in);
    } else {
      b = c.raw_bit(in);
    }
    value = (value << 1) | uint32_t(b);
  }
  const int32_t out = int32_t(value);
  return neg ? -out : out;
}

template <typename Coder>
void code_field(Coder& c, std::span<int32_t> v, const FieldShape& s, const ExtraCandidates& extra) {
  const int64_t w = s.width, h = s.height;
  if (w == 0 || h == 0) return;
  const int32_t span = int32_t(1) << s.bits;
  const int32_t half = span >> 1;
  const int32_t lo = s.lo, hi = s.lo + span - 1;
  const bool signed_field = lo < 0;
  const int nbase = signed_field ? kCandidates : kCandidates - 1;
  const int nextra = int(extra.count);
  const int ncand = nbase + nextra;

  auto model = std::make_unique<Model>();
  Model& m = *model;
  // Per-row errors (two rows, one column of padding each side): candidate errors for the
  // blend weights, final signed residuals for contexts.
  const int64_t stride = w + 2;
  std::vector<uint32_t> cerr(size_t(2 * stride * kStride), 0);
  std::vector<int32_t> ferr(size_t(2 * stride), 0);

  for (int64_t y = 0; y < h; ++y) {
    int32_t* row = v.data() + y * w;
    const int32_t* up = y > 0 ? row - w : nullptr;
    const int32_t* up2 = y > 1 ? row - 2 * w : nullptr;
    uint32_t* ce_cur = cerr.data() + ((y & 1) * stride + 1) * kStride;
    const uint32_t* ce_up = cerr.data() + (((y + 1) & 1) * stride + 1) * kStride;
    int32_t* fe_cur = ferr.data() + (y & 1) * stride + 1;
    const int32_t* fe_up = ferr.data() + ((y + 1) & 1) * stride + 1;
    if (y == 0) {
      // No row above: make the "row above" errors neutral.
      std::fill(cerr.begin() + ((1 * stride) * kStride), cerr.begin() + (2 * stride * kStride), 0u);
      std::fill(ferr.begin() + stride, ferr.end(), 0);
    }
    for (int64_t x = 0; x < w; ++x) {
      // Neighbours with edge rules: missing ones copy the nearest causal sample.
      int32_t W, N, NW, NE, WW, NN;
      if (y == 0) {
        W = x > 0 ? row[x - 1] : lo + half;
        N = NW = NE = NN = W;
        WW = x > 1 ? row[x - 2] : W;
      } else {
        N = up[x];
        W = x > 0 ? row[x - 1] : N;
        NW = x > 0 ? up[x - 1] : N;
        NE = x + 1 < w ? up[x + 1] : N;
        WW = x > 1 ? row[x - 2] : W;
        NN = up2 ? up2[x] : N;
      }
      std::array<int32_t, kStride> p{};
      p[0] = W;
      p[1] = N;
      p[2] = W + N - NW;
      p[3] = W + NE - N;
      p[4] = 2 * W - WW;
      p[5] = 2 * N - NN;
      p[6] = (W + NE + 1) >> 1;
      p[7] = 0;
      for (int k = 0; k < nextra; ++k)
        p[size_t(nbase + k)] =
            extra.values[size_t((y * w + x) * nextra + k)] + ((extra.w_relative >> k) & 1u ? W : 0);

      // Blend: weight each candidate by the inverse square of its error around here.
      const uint32_t* cu = ce_up + x * kStride;
      const uint32_t* cc = ce_cur + x * kStride;
      int64_t num = 0, den = 0;
      uint32_t smin = 0xFFFFFFFFu;
      for (int k = 0; k < ncand; ++k) {
        const uint32_t sc =
            cu[k] + cu[-kStride + k] + cu[kStride + k] + cc[-kStride + k] * 2;  // N, NW, NE, W (twice)
        smin = std::min(smin, sc);
        const uint64_t s1 = uint64_t(sc) + 1;
        int64_t wk = int64_t((uint64_t(1) << 32) / (s1 * s1));
        if (wk < 1) wk = 1;
        num += wk * p[k];
        den += wk;
      }
      int64_t pred_fp = floor_div_pos((num << kFracBits) + den / 2, den);
      pred_fp = std::clamp<int64_t>(pred_fp, int64_t(lo) << kFracBits, int64_t(hi) << kFracBits);

      // Error energy around the sample selects the coding context.
      const int32_t eW = fe_cur[x - 1], eN = fe_up[x], eNW = fe_up[x - 1], eNE = fe_up[x + 1];
      uint32_t act = uint32_t(2 * std::abs(eW) + 2 * std::abs(eN) + std::abs(eNW) + std::abs(eNE)) +
                     std::min<uint32_t>(smin, 1u << 20) / 2;
      const int ctx = activity_bucket(act);

      // Bias correction per (energy, texture) context: the sign pattern of the neighbours
      // against the prediction tells a slope break from noise.
      const int32_t pf = int32_t(pred_fp);
      const int tex = (int64_t(N) << kFracBits > pf) | ((int64_t(W) << kFracBits > pf) << 1) |
                      ((int64_t(NW) << kFracBits > pf) << 2) | ((int64_t(NE) << kFracBits > pf) << 3) |
                      ((int64_t(WW) << kFracBits > pf) << 4) | ((int64_t(NN) << kFracBits > pf) << 5);
      const int bctx = tex * kBiasBuckets + std::min(ctx / 3, kBiasBuckets - 1);
      const int32_t cnt = m.bias_count[bctx];
      const int32_t corr = cnt > 0 ? m.bias_sum[bctx] / cnt : 0;
      int64_t final_fp = pred_fp + corr;
      int32_t pred = int32_t((final_fp + (1 << (kFracBits - 1))) >> kFracBits);
      pred = std::clamp(pred, lo, hi);

      int32_t e = 0;
      if constexpr (!Coder::kDecoding) {
        e = row[x] - pred;
        e = ((e + half) & (span - 1)) - half;
      }
      const int sctx = sign3(eW) * 3 + sign3(eN);
      e = code_residual(c, m, ctx, sctx, s.bits, e);
      const int32_t val = lo + ((pred + e - lo) & (span - 1));
      if constexpr (Coder::kDecoding) row[x] = val;

      // Update errors and bias statistics.
      fe_cur[x] = ((val - pred + half) & (span - 1)) - half;
      for (int k = 0; k < ncand; ++k) {
        const int64_t d = int64_t(val) - p[k];
        ce_cur[x * kStride + k] = uint32_t(std::min<int64_t>(d < 0 ? -d : d, 1 << 18));
      }
      const int32_t berr =
          std::clamp<int32_t>(int32_t((int64_t(val) << kFracBits) - pred_fp), -(1 << 20), 1 << 20);
      m.bias_sum[bctx] += berr;
      if (++m.bias_count[bctx] >= 128) {
        m.bias_sum[bctx] /= 2;
        m.bias_count[bctx] = 64;
      }
    }
    // Right padding mirrors the last column so NE at the edge sees a plausible error.
    fe_cur[w] = fe_cur[w - 1];
    for (int k = 0; k < kStride; ++k) ce_cur[w * kStride + k] = ce_cur[(w - 1) * kStride + k];
    fe_cur[-1] = 0;
    for (int k = 0; k < kStride; ++k) ce_cur[-kStride + k] = 0;
  }
}

}  // namespace

void encode_field(std::span<int32_t> values, const FieldShape& shape, RangeEncoder& enc,
                  const ExtraCandidates& extra) {
  code_field(enc, values, shape, extra);
}

void decode_field(std::span<int32_t> out, const FieldShape& shape, RangeDecoder& dec,
                  const ExtraCandidates& extra) {
  code_field(dec, out, shape, extra);
}

}  // namespace loam::codec
