#include "protocol/codec/predictor.h"

// The forward transform has no loop-carried dependency; GCC vectorizes it only above -O2's
// very-cheap cost model. (clang vectorizes it at -O2 already.)
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("O3")
#endif

namespace loam::codec {

namespace {

// The row loops are split into the first row, the first column and the interior so the
// interior runs without edge branches.
//
// The forward interior uses MED in the form min + max - clamp(NW, min, max). It equals
// clamp(W + N - NW, min, max) (NW above both gives min, below both gives max, else
// W + N - NW), but it only ever compares samples, never a sum, so it is exact in wrapping
// 16-bit lanes. The samples are biased by 0x8000 into int16 because SSE2, the x86-64
// baseline, has signed 16-bit min/max only; the bias cancels in the residual. That lets
// the compiler vectorize the whole pass (shift, predict, zigzag, split) eight or sixteen
// samples at a time.
[[gnu::always_inline]] inline void forward_kernel(const uint16_t* __restrict s, uint32_t width,
                                                  uint32_t height, uint32_t shift, uint8_t* __restrict lo,
                                                  uint8_t* __restrict hi) {
  auto put = [&](size_t i, uint16_t r) {
    const uint16_t z = zigzag16(int16_t(r));
    lo[i] = uint8_t(z);
    hi[i] = uint8_t(z >> 8);
  };
  uint16_t prev = 0;
  for (uint32_t x = 0; x < width; ++x) {
    const uint16_t v = uint16_t(s[x] >> shift);
    put(x, uint16_t(v - prev));
    prev = v;
  }
  for (uint32_t y = 1; y < height; ++y) {
    const size_t r = size_t(y) * width;
    const uint16_t* cur = s + r;
    const uint16_t* up = cur - width;
    put(r, uint16_t((cur[0] >> shift) - (up[0] >> shift)));
    for (uint32_t x = 1; x < width; ++x) {
      const auto biased = [shift](uint16_t v) { return int16_t(uint16_t(v >> shift) ^ 0x8000u); };
      const int16_t w = biased(cur[x - 1]), n = biased(up[x]), nw = biased(up[x - 1]);
      const int16_t mn = std::min(w, n), mx = std::max(w, n);
      const int16_t c = std::min(std::max(nw, mn), mx);
      const uint16_t pred = uint16_t(mn + mx - c);
      put(r + x, uint16_t(uint16_t(biased(cur[x])) - pred));
    }
  }
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define LOAM_MED_AVX2 1
// The same kernel compiled for AVX2 (sixteen lanes); chosen at run time by detected_isa().
__attribute__((target("avx2"))) void forward_avx2(const uint16_t* s, uint32_t width, uint32_t height,
                                                  uint32_t shift, uint8_t* lo, uint8_t* hi) {
  forward_kernel(s, width, height, shift, lo, hi);
}
#endif

void forward_portable(const uint16_t* s, uint32_t width, uint32_t height, uint32_t shift, uint8_t* lo,
                      uint8_t* hi) {
  forward_kernel(s, width, height, shift, lo, hi);
}

}  // namespace

Isa detected_isa() {
#ifdef LOAM_MED_AVX2
  static const Isa isa = __builtin_cpu_supports("avx2") ? Isa::kAvx2 : Isa::kPortable;
  return isa;
#else
  return Isa::kPortable;
#endif
}

void med_forward_u16(std::span<const uint16_t> in, uint32_t width, uint32_t height, uint32_t shift,
                     std::span<uint8_t> lo, std::span<uint8_t> hi, Isa isa) {
#ifdef LOAM_MED_AVX2
  if (isa == Isa::kAvx2 && detected_isa() == Isa::kAvx2) {
    forward_avx2(in.data(), width, height, shift, lo.data(), hi.data());
    return;
  }
#else
  (void)isa;
#endif
  forward_portable(in.data(), width, height, shift, lo.data(), hi.data());
}

void med_forward_u16(std::span<const uint16_t> in, uint32_t width, uint32_t height, std::span<uint8_t> out) {
  const size_t n = size_t(width) * height;
  med_forward_u16(in, width, height, 0, out.first(n), out.subspan(n, n));
}

void med_inverse_u16(std::span<const uint8_t> lo_plane, std::span<const uint8_t> hi_plane, uint32_t width,
                     uint32_t height, std::span<uint16_t> out) {
  const uint8_t* lo = lo_plane.data();
  const uint8_t* hi = hi_plane.data();
  uint16_t* s = out.data();
  // The planes are joined and unzigzagged into `out` first, in a pass the compiler
  // vectorizes; the serial pass below then replaces each residual by its sample in place
  // (a sample's residual is read just before it is overwritten, and its neighbours are
  // already samples). That halves the serial pass's instructions.
  const size_t n = size_t(width) * height;
  for (size_t i = 0; i < n; ++i) s[i] = uint16_t(unzigzag16(uint16_t(lo[i] | (hi[i] << 8))));
  auto res = [&](size_t i) -> int32_t { return s[i]; };
  uint16_t prev = 0;
  for (uint32_t x = 0; x < width; ++x) {
    prev = uint16_t(prev + res(x));
    s[x] = prev;
  }
  // One sample with both edge rules, W read back from memory: for the ragged ends.
  auto cell = [&](uint32_t y, uint32_t x) {
    const size_t i = size_t(y) * width + x;
    if (x == 0) {
      s[i] = uint16_t(s[i - width] + res(i));
    } else {
      s[i] = uint16_t(med(s[i - 1], s[i - width], s[i - width - 1]) + res(i));
    }
  };
  uint32_t y = 1;
  // Decoding is a serial chain through W (min, max, clamp, add per sample), so one row at a
  // time leaves the core waiting on latency. Four rows are kept in flight instead, each one
  // column behind the row above: row y+k at column t-k needs the row above at columns t-k
  // and t-k-1, which that row finished one and two steps earlier. The four chains are
  // independent and overlap; the W values stay in registers.
  for (; y + 4 <= height; y += 4) {
    const uint32_t steps = width + 3;
    auto ragged_step = [&](uint32_t t) {
      for (uint32_t k = 0; k < 4; ++k)
        if (t >= k && t - k < width) cell(y + k, t - k);
    };
    uint32_t t = 0;
    for (; t < std::min<uint32_t>(4, steps); ++t) ragged_step(t);
    if (width > 4) {
      const size_t r0 = size_t(y) * width;
      uint16_t* c0 = s + r0;
      const uint16_t* u0 = c0 - width;  // the row above the group
      uint16_t* c1 = c0 + width;
      uint16_t* c2 = c1 + width;
      uint16_t* c3 = c2 + width;
      int32_t w0 = c0[t - 1], w1 = c1[t - 2], w2 = c2[t - 3], w3 = c3[t - 4];
      for (; t < width; ++t) {
        const size_t i0 = r0 + t;
        w0 = uint16_t(med(w0, u0[t], u0[t - 1]) + res(i0));
        c0[t] = uint16_t(w0);
        w1 = uint16_t(med(w1, c0[t - 1], c0[t - 2]) + res(i0 + width - 1));
        c1[t - 1] = uint16_t(w1);
        w2 = uint16_t(med(w2, c1[t - 2], c1[t - 3]) + res(i0 + 2 * width - 2));
        c2[t - 2] = uint16_t(w2);
        w3 = uint16_t(med(w3, c2[t - 3], c2[t - 4]) + res(i0 + 3 * width - 3));
        c3[t - 3] = uint16_t(w3);
      }
    }
    for (; t < steps; ++t) ragged_step(t);
  }
  for (; y < height; ++y)
    for (uint32_t x = 0; x < width; ++x) cell(y, x);
}

void med_inverse_u16(std::span<const uint8_t> planes, uint32_t width, uint32_t height,
                     std::span<uint16_t> out) {
  const size_t n = size_t(width) * height;
  med_inverse_u16(planes.first(n), planes.subspan(n, n), width, height, out);
}

void med_forward_i8(std::span<const int8_t> in, uint32_t width, uint32_t height, std::span<uint8_t> out) {
  const int8_t* s = in.data();
  int8_t prev = 0;
  for (uint32_t x = 0; x < width; ++x) {
    out[x] = zigzag8(int8_t(s[x] - prev));
    prev = s[x];
  }
  for (uint32_t y = 1; y < height; ++y) {
    const size_t r = size_t(y) * width;
    const int8_t* cur = s + r;
    const int8_t* up = cur - width;
    out[r] = zigzag8(int8_t(cur[0] - up[0]));
    for (uint32_t x = 1; x < width; ++x) {
      const int32_t p = med(cur[x - 1], up[x], up[x - 1]);
      out[r + x] = zigzag8(int8_t(cur[x] - p));
    }
  }
}

void med_inverse_i8(std::span<const uint8_t> plane, uint32_t width, uint32_t height, std::span<int8_t> out) {
  int8_t* s = out.data();
  int8_t prev = 0;
  for (uint32_t x = 0; x < width; ++x) {
    prev = int8_t(prev + unzigzag8(plane[x]));
    s[x] = prev;
  }
  for (uint32_t y = 1; y < height; ++y) {
    const size_t r = size_t(y) * width;
    int8_t* cur = s + r;
    const int8_t* up = cur - width;
    cur[0] = int8_t(up[0] + unzigzag8(plane[r]));
    for (uint32_t x = 1; x < width; ++x) {
      const int32_t p = med(cur[x - 1], up[x], up[x - 1]);
      cur[x] = int8_t(p + unzigzag8(plane[r + x]));
    }
  }
}

}  // namespace loam::codec
