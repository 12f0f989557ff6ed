#include "protocol/codec/refine_coder.h"

#include <algorithm>
#include <vector>

#include "protocol/codec/field_coder.h"
#include "protocol/codec/predictor.h"

namespace loam::codec {
namespace {

// Clamps an even coordinate into [0, the last even coordinate below n].
int64_t even_clamp(int64_t i, int64_t n) { return std::clamp<int64_t>(i, 0, (n - 1) & ~int64_t(1)); }

// Predictions of one sample from samples already known: the base the residual is taken
// against, and other candidates for the field coder to blend in (docs/codec.md, "refine").
struct Prediction {
  int32_t base = 0;
  int32_t extra[kMaxExtraCandidates] = {};
};

// One pass: the samples (x0 + sx i, y0 + 2j), i < fw, j < fh, in raster order, coded as a
// field of residuals against `predict`'s base; candidates whose bit is set in w_relative
// are offsets from the field's W (their sample to the left is not known before the pass).
template <typename Coder, typename Predict>
void code_pass(Coder& c, std::span<int32_t> v, int64_t w, int64_t x0, int64_t sx, int64_t y0, int64_t fw,
               int64_t fh, int bits, uint32_t nextra, uint32_t w_relative, Predict&& predict) {
  if (fw <= 0 || fh <= 0) return;
  const int32_t hi = (int32_t(1) << bits) - 1;
  const size_t n = size_t(fw * fh);
  std::vector<int32_t> base(n), r(n), extra(n * nextra);
  for (int64_t j = 0; j < fh; ++j)
    for (int64_t i = 0; i < fw; ++i) {
      const int64_t x = x0 + sx * i, y = y0 + 2 * j;
      const size_t k = size_t(j * fw + i);
      const Prediction p = predict(x, y);
      base[k] = p.base;
      for (uint32_t q = 0; q < nextra; ++q)
        extra[k * nextra + q] = (w_relative >> q) & 1u ? p.extra[q] : p.extra[q] - p.base;
      if constexpr (!Coder::kDecoding) r[k] = v[size_t(y * w + x)] - p.base;
    }
  const FieldShape fs{uint32_t(fw), uint32_t(fh), bits + 1, -(int32_t(1) << bits)};
  const ExtraCandidates candidates{extra, nextra, w_relative};
  if constexpr (Coder::kDecoding) {
    decode_field(r, fs, c, candidates);
  } else {
    encode_field(r, fs, c, candidates);
  }
  for (int64_t j = 0; j < fh; ++j)
    for (int64_t i = 0; i < fw; ++i) {
      const size_t k = size_t(j * fw + i);
      v[size_t((y0 + 2 * j) * w + x0 + sx * i)] = (base[k] + r[k]) & hi;
    }
}

template <typename Coder>
void code_refinement(Coder& c, std::span<int32_t> v, uint32_t width, uint32_t height, int bits) {
  const int32_t lo = 0, hi = (int32_t(1) << bits) - 1;
  const int64_t w = width, h = height;
  auto at = [&](int64_t x, int64_t y) { return v[size_t(y * w + x)]; };

  // Pass A, odd columns of even rows: cubic between the even neighbours, linear as the
  // other candidate.
  code_pass(c, v, w, 1, 2, 0, w / 2, (h + 1) / 2, bits, 1, 0, [&](int64_t x, int64_t y) {
    const int32_t a = at(even_clamp(x - 3, w), y), b = at(x - 1, y), cc = at(even_clamp(x + 1, w), y),
                  d = at(even_clamp(x + 3, w), y);
    Prediction p;
    p.base = cubic_mid(a, b, cc, d, lo, hi);
    p.extra[0] = (b + cc + 1) >> 1;
    return p;
  });
  // Pass B, every sample of the odd rows, between the complete even rows: linear from
  // above and below, the cubic through four rows, and two predictions from the sample to
  // the left plus the horizontal gradient of the rows above and below (over two columns
  // and over one), taken relative to W.
  code_pass(c, v, w, 0, 1, 1, w, h / 2, bits, 3, 6u, [&](int64_t x, int64_t y) {
    const int64_t yu = y - 1, yd = even_clamp(y + 1, h);
    const int32_t a = at(x, even_clamp(y - 3, h)), b = at(x, yu), cc = at(x, yd),
                  d = at(x, even_clamp(y + 3, h));
    Prediction p;
    p.base = (b + cc + 1) >> 1;
    p.extra[0] = cubic_mid(a, b, cc, d, lo, hi);
    if (x > 0 && x + 1 < w) {
      // W's base is the same linear interpolation one column to the left; the residual
      // field's W plus (W's base - this base + gradient) is W's sample plus the gradient.
      const int32_t w_base = (at(x - 1, yu) + at(x - 1, yd) + 1) >> 1;
      p.extra[1] =
          w_base - p.base + ((at(x + 1, yu) - at(x - 1, yu)) + (at(x + 1, yd) - at(x - 1, yd)) + 2) / 4;
      p.extra[2] = w_base - p.base + ((at(x, yu) - at(x - 1, yu)) + (at(x, yd) - at(x - 1, yd)) + 1) / 2;
    }
    return p;
  });
}

}  // namespace

void encode_refinement(RangeEncoder& enc, std::span<int32_t> v, uint32_t width, uint32_t height, int bits) {
  code_refinement(enc, v, width, height, bits);
}
void decode_refinement(RangeDecoder& dec, std::span<int32_t> v, uint32_t width, uint32_t height, int bits) {
  code_refinement(dec, v, width, height, bits);
}

}  // namespace loam::codec
