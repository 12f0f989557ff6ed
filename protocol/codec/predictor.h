// Predictors shared by the region codec's modes: the MED (LOCO-I median edge detector)
// residual transform of format version 2's fast mode (decoded for old snapshots; the
// benchmark's MED + byte planes + zstd-1 baseline), and the cubic interpolation of the
// refinement mode. Also the run-time ISA choice of the codec's vectorized kernels.
// Pure arithmetic on caller-sized spans: safe on any input values; callers guarantee sizes.
#pragma once

#include <algorithm>
#include <cstdint>
#include <span>

namespace loam::codec {

// MED prediction: the median of W, N and W + N - NW (picks W or N across an edge, the plane
// elsewhere), written as min + max - clamp(NW, min, max), which is the same value (NW above
// both gives min, below both gives max, else W + N - NW). With std::clamp(W + N - NW, ...)
// GCC 12 emits two data-dependent branches that mispredict on rough terrain and dominated
// the decoder; this form compiles to compares and conditional moves only.
inline int32_t med(int32_t w, int32_t n, int32_t nw) {
  const int32_t mn = w < n ? w : n;
  const int32_t mx = w < n ? n : w;
  int32_t c = nw < mn ? mn : nw;
  c = c > mx ? mx : c;
  return mn + mx - c;
}

// Zigzag maps signed residuals to unsigned so small magnitudes of either sign are small.
inline uint16_t zigzag16(int16_t r) { return uint16_t((uint16_t(r) << 1) ^ uint16_t(r >> 15)); }
inline int16_t unzigzag16(uint16_t z) { return int16_t((z >> 1) ^ uint16_t(-(int32_t)(z & 1u))); }
inline uint8_t zigzag8(int8_t r) { return uint8_t((uint8_t(r) << 1) ^ uint8_t(r >> 7)); }
inline int8_t unzigzag8(uint8_t z) { return int8_t((z >> 1) ^ uint8_t(-(int32_t)(z & 1u))); }

// Which instruction set the codec's kernels (these MED transforms, the fast mode's coder)
// run on. Every choice computes the same integers, so the bytes never depend on the machine;
// kAvx2 is taken only where the CPU reports it at run time (the build targets baseline
// x86-64, where the compiler's SSE2 vectorization is the portable path).
enum class Isa : uint8_t { kPortable = 0, kAvx2 = 1 };
Isa detected_isa();

// MED residuals of a width x height uint16 grid, each sample first shifted right by `shift`
// (0..15), as two byte planes of zigzag values: low bytes into lo[0, n), high bytes into
// hi[0, n), n = width * height. Separate planes let the entropy coder model each byte's
// distribution by itself (the high plane is nearly all zeros on terrain).
void med_forward_u16(std::span<const uint16_t> in, uint32_t width, uint32_t height, uint32_t shift,
                     std::span<uint8_t> lo, std::span<uint8_t> hi, Isa isa = detected_isa());
// The inverse (without the shift: the caller restores the low bits).
void med_inverse_u16(std::span<const uint8_t> lo, std::span<const uint8_t> hi, uint32_t width,
                     uint32_t height, std::span<uint16_t> out);
// The same with the planes adjacent in one buffer (lo at [0, n), hi at [n, 2n)) and no
// shift: the plain MED + byte planes baseline the benchmark compares against.
void med_forward_u16(std::span<const uint16_t> in, uint32_t width, uint32_t height, std::span<uint8_t> out);
void med_inverse_u16(std::span<const uint8_t> planes, uint32_t width, uint32_t height,
                     std::span<uint16_t> out);
// The same for int8 samples: one plane of zigzag residuals modulo 256.
void med_forward_i8(std::span<const int8_t> in, uint32_t width, uint32_t height, std::span<uint8_t> out);
void med_inverse_i8(std::span<const uint8_t> plane, uint32_t width, uint32_t height, std::span<int8_t> out);

// Cubic (Catmull-Rom at the midpoint) interpolation between b and c with outer samples a and
// d: (-a + 9b + 9c - d) / 16, rounded, clamped to [lo, hi].
inline int32_t cubic_mid(int32_t a, int32_t b, int32_t c, int32_t d, int32_t lo, int32_t hi) {
  return std::clamp((9 * (b + c) - a - d + 8) >> 4, lo, hi);
}

}  // namespace loam::codec
