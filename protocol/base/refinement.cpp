#include "protocol/base/refinement.h"

#include <xxhash.h>

#include <algorithm>
#include <cassert>
#include <string>

namespace loam {

namespace {

// Values travel in 1/16 height units. Bit budget: sources are clamped to +-2^21 units
// (2^25 sixteenths) and every level's values to +-2^26, so an interpolation sums at most
// 20 * 2^26 < 2^31 and a displacement adds at most 2^16 * 2^20 * 2^16 >> 24 = 2^28.
constexpr int32_t kSourceLimit = 1 << 21;
constexpr int64_t kValueLimit = int64_t(1) << 26;
constexpr int32_t kMaxAmplitude = 1 << 20;
constexpr int32_t kMaxRoughnessParam = 1 << 16;

int32_t clamp_value(int64_t v) { return int32_t(std::clamp(v, -kValueLimit, kValueLimit)); }

// MurmurHash3's 64-bit finaliser: every input bit reaches every output bit.
constexpr uint64_t mix64(uint64_t k) {
  k ^= k >> 33;
  k *= 0xff51afd7ed558ccdull;
  k ^= k >> 33;
  k *= 0xc4ceb9fe1a85ec53ull;
  k ^= k >> 33;
  return k;
}

// Dubuc-Deslauriers 4-point midpoint between b and c, rounded half up (arithmetic shifts
// are floors in C++20, so this is the same on every compiler).
inline int64_t midpoint4(int32_t a, int32_t b, int32_t c, int32_t d) {
  return (int64_t(9) * (int64_t(b) + c) - a - d + 8) >> 4;
}

// The displacement of the sample inserted at level-L position (i, j): a triangular variate
// in [-1, 1) (sum of two 16-bit halves of the hash) times amplitude times roughness / 256.
inline int64_t displacement(uint64_t level_seed, int64_t i, int64_t j, int32_t amplitude, int32_t roughness) {
  const uint64_t h = mix64(((uint64_t(uint32_t(i)) << 32) | uint32_t(j)) ^ level_seed);
  const int64_t variate = int64_t(int16_t(uint16_t(h >> 48))) + int64_t(int16_t(uint16_t(h >> 32)));
  return (variate * amplitude * roughness) >> 24;
}

// A rectangle of one level's lattice with heights (1/16 units) and roughness (1/256).
struct Plane {
  int64_t x0 = 0, y0 = 0;
  int64_t w = 0, h = 0;
  std::vector<int32_t> v, r;
  void reset(int64_t nx0, int64_t ny0, int64_t nw, int64_t nh) {
    x0 = nx0;
    y0 = ny0;
    w = nw;
    h = nh;
    v.resize(size_t(w * h));
    r.resize(size_t(w * h));
  }
};

// The parent-level range whose samples determine level samples [x0, x1): each sample
// needs its parent (even) or the four parents around it (odd).
RectI parent_region(const RectI& r) {
  return {(r.x0 >> 1) - 1, (r.y0 >> 1) - 1, ((r.x1 - 1) >> 1) + 3, ((r.y1 - 1) >> 1) + 3};
}

struct Scratch {
  Plane a, b, x;
};

Scratch& scratch() {
  thread_local Scratch s;
  return s;
}

}  // namespace

Status RefinementParams::validate() const {
  if (levels < 1 || levels > kMaxRefineLevels)
    return make_error(ErrorCode::kInvalidArgument, "refinement.levels",
                      "must be 1.." + std::to_string(kMaxRefineLevels) + ", got " + std::to_string(levels));
  for (size_t l = 0; l < amplitude.size(); ++l) {
    if (amplitude[l] < 0 || amplitude[l] > kMaxAmplitude)
      return make_error(
          ErrorCode::kInvalidArgument, "refinement.amplitude[" + std::to_string(l) + "]",
          "must be 0.." + std::to_string(kMaxAmplitude) + ", got " + std::to_string(amplitude[l]));
  }
  const auto check = [](int32_t v, const char* field) -> Status {
    if (v < 0 || v > kMaxRoughnessParam)
      return make_error(ErrorCode::kInvalidArgument, field,
                        "must be 0.." + std::to_string(kMaxRoughnessParam) + ", got " + std::to_string(v));
    return {};
  };
  LOAM_TRY(check(roughness_base, "refinement.roughness_base"));
  LOAM_TRY(check(roughness_gain, "refinement.roughness_gain"));
  LOAM_TRY(check(roughness_max, "refinement.roughness_max"));
  return {};
}

Result<RefinedBase> RefinedBase::create(int32_t width, int32_t height, std::span<const int32_t> source,
                                        const RefinementParams& params) {
  LOAM_TRY(params.validate());
  if (width < 1 || width > 65536 || height < 1 || height > 65536)
    return make_error(
        ErrorCode::kInvalidArgument, "refinement.source",
        "size must be 1..65536 per axis, got " + std::to_string(width) + "x" + std::to_string(height));
  if (source.size() != size_t(width) * size_t(height))
    return make_error(ErrorCode::kInvalidArgument, "refinement.source",
                      "has " + std::to_string(source.size()) + " samples for " + std::to_string(width) + "x" +
                          std::to_string(height));
  RefinedBase base;
  base.params_ = params;
  base.width_ = width;
  base.height_ = height;
  base.source16_.resize(source.size());
  for (size_t i = 0; i < source.size(); ++i)
    base.source16_[i] = std::clamp(source[i], -kSourceLimit, kSourceLimit) * 16;
  base.roughness_.resize(source.size());
  for (int32_t y = 0; y < height; ++y) {
    for (int32_t x = 0; x < width; ++x) {
      int32_t lo = INT32_MAX, hi = INT32_MIN;
      for (int32_t dy = -1; dy <= 1; ++dy) {
        for (int32_t dx = -1; dx <= 1; ++dx) {
          const int32_t sx = std::clamp(x + dx, 0, width - 1), sy = std::clamp(y + dy, 0, height - 1);
          const int32_t v = base.source16_[size_t(sy) * size_t(width) + size_t(sx)] / 16;
          lo = std::min(lo, v);
          hi = std::max(hi, v);
        }
      }
      const int64_t rough =
          int64_t(params.roughness_base) + ((int64_t(params.roughness_gain) * (hi - lo)) >> 8);
      base.roughness_[size_t(y) * size_t(width) + size_t(x)] =
          int32_t(std::clamp<int64_t>(rough, 0, params.roughness_max));
    }
  }
  for (int32_t l = 0; l < kMaxRefineLevels; ++l)
    base.level_seed_[size_t(l)] = mix64(params.seed ^ mix64(uint64_t(l) + 0x9e3779b97f4a7c15ull));
  // Identity: method tag, parameters and source as little-endian integers (x86 and ARM alike).
  std::vector<int64_t> id = {0x3176657266656e69 /* "inefref1" */,
                             width,
                             height,
                             params.levels,
                             int64_t(params.seed),
                             params.roughness_base,
                             params.roughness_gain,
                             params.roughness_max};
  for (int32_t a : params.amplitude) id.push_back(a);
  for (int32_t v : base.source16_) id.push_back(v);
  base.identity_ = XXH3_64bits(id.data(), id.size() * sizeof(int64_t));
  return base;
}

void RefinedBase::generate(int32_t mip, const RectI& rect, std::span<uint16_t> out) const {
  assert(mip >= 0 && mip < kMaxMips);
  assert(rect.x1 > rect.x0 && rect.y1 > rect.y0 && out.size() == size_t(rect.area()));
  const int32_t levels = params_.levels;
  const auto source_at = [&](int64_t sx, int64_t sy) {
    sx = std::clamp<int64_t>(sx, 0, width_ - 1);
    sy = std::clamp<int64_t>(sy, 0, height_ - 1);
    return size_t(sy) * size_t(width_) + size_t(sx);
  };
  const auto to_height = [](int64_t v16) { return uint16_t(std::clamp<int64_t>((v16 + 8) >> 4, 0, 65535)); };

  if (mip >= levels) {
    // Every sample is a source sample.
    const int32_t shift = mip - levels;
    size_t o = 0;
    for (int64_t j = rect.y0; j < rect.y1; ++j)
      for (int64_t i = rect.x0; i < rect.x1; ++i)
        out[o++] = to_height(source16_[source_at(i << shift, j << shift)]);
    return;
  }

  // Regions from the requested level up to the source.
  std::array<RectI, kMaxRefineLevels + 1> region;
  region[size_t(mip)] = rect;
  for (int32_t l = mip; l < levels; ++l) region[size_t(l + 1)] = parent_region(region[size_t(l)]);

  Scratch& s = scratch();
  Plane* parent = &s.a;
  Plane* child = &s.b;
  {
    const RectI& top = region[size_t(levels)];
    parent->reset(top.x0, top.y0, top.width(), top.height());
    size_t o = 0;
    for (int64_t j = top.y0; j < top.y1; ++j) {
      for (int64_t i = top.x0; i < top.x1; ++i, ++o) {
        const size_t k = source_at(i, j);
        parent->v[o] = source16_[k];
        parent->r[o] = roughness_[k];
      }
    }
  }

  for (int32_t level = levels - 1; level >= mip; --level) {
    const RectI& R = region[size_t(level)];
    const uint64_t seed = level_seed_[size_t(level)];
    const int32_t amp = params_.amplitude[size_t(level)];
    // Along x: this level's columns on the parent's rows.
    Plane& X = s.x;
    X.reset(R.x0, parent->y0, R.width(), parent->h);
    for (int64_t pb = 0; pb < parent->h; ++pb) {
      const int32_t* pv = parent->v.data() + pb * parent->w;
      const int32_t* pr = parent->r.data() + pb * parent->w;
      int32_t* xv = X.v.data() + pb * X.w;
      int32_t* xr = X.r.data() + pb * X.w;
      const int64_t j = (parent->y0 + pb) * 2;
      for (int64_t i = R.x0; i < R.x1; ++i) {
        const int64_t a = (i >> 1) - parent->x0;
        const size_t o = size_t(i - R.x0);
        if ((i & 1) == 0) {
          xv[o] = pv[a];
          xr[o] = pr[a];
        } else {
          const int32_t rough = (pr[a] + pr[a + 1] + 1) >> 1;
          xr[o] = rough;
          xv[o] = clamp_value(midpoint4(pv[a - 1], pv[a], pv[a + 1], pv[a + 2]) +
                              displacement(seed, i, j, amp, rough));
        }
      }
    }
    // Along y: every row of this level from the rows above.
    child->reset(R.x0, R.y0, R.width(), R.height());
    for (int64_t j = R.y0; j < R.y1; ++j) {
      const int64_t b = (j >> 1) - X.y0;
      int32_t* cv = child->v.data() + (j - R.y0) * child->w;
      int32_t* cr = child->r.data() + (j - R.y0) * child->w;
      const int32_t* r1 = X.v.data() + b * X.w;
      const int32_t* q1 = X.r.data() + b * X.w;
      if ((j & 1) == 0) {
        std::copy(r1, r1 + X.w, cv);
        std::copy(q1, q1 + X.w, cr);
        continue;
      }
      const int32_t* r0 = r1 - X.w;
      const int32_t* r2 = r1 + X.w;
      const int32_t* r3 = r2 + X.w;
      const int32_t* q2 = q1 + X.w;
      for (int64_t o = 0; o < X.w; ++o) {
        const int32_t rough = (q1[o] + q2[o] + 1) >> 1;
        cr[o] = rough;
        cv[o] =
            clamp_value(midpoint4(r0[o], r1[o], r2[o], r3[o]) + displacement(seed, R.x0 + o, j, amp, rough));
      }
    }
    std::swap(parent, child);
  }

  for (size_t k = 0; k < out.size(); ++k) out[k] = to_height(parent->v[k]);
}

}  // namespace loam
