#include "protocol/stamps/stamp_profile.h"

#include <cmath>

namespace loam {

double exact_exp_neg(double x) {
  if (!(x > 0.0)) return 1.0;
  if (x > 700.0) return 0.0;
  // Halve until |y| <= 1/16, so 12 Taylor terms are below double precision.
  int k = 0;
  double y = x;
  while (y > 0.0625) {
    y = y / 2.0;
    ++k;
  }
  double term = 1.0, sum = 1.0;
  for (int n = 1; n <= 12; ++n) {
    term = term * (-y) / double(n);
    sum = sum + term;
  }
  for (int i = 0; i < k; ++i) sum = sum * sum;
  return sum;
}

namespace {

// sin and cos of a in [0, pi/4] by Taylor series (14 terms; below an ulp at pi/4).
void sincos_small(double a, double& s, double& c) {
  const double a2 = a * a;
  double ts = a, tc = 1.0;
  s = a;
  c = 1.0;
  for (int n = 1; n <= 14; ++n) {
    ts = -ts * a2 / double((2 * n) * (2 * n + 1));
    tc = -tc * a2 / double((2 * n - 1) * (2 * n));
    s = s + ts;
    c = c + tc;
  }
}

int32_t round_q15(double v) {
  const double scaled = v * 32768.0;
  return scaled >= 0 ? int32_t(scaled + 0.5) : -int32_t(-scaled + 0.5);
}

}  // namespace

void rotation_q15(uint16_t rotation, int32_t& cos_q15, int32_t& sin_q15) {
  // Split the turn into octants with integers, so the series only sees [0, pi/4].
  constexpr double kPi = 3.141592653589793;  // nearest double to pi
  const uint32_t r = rotation;
  const uint32_t quadrant = r >> 14;                    // 16384 units per quarter turn
  uint32_t within = r & 16383u;                         // 0..16383 inside the quadrant
  const bool upper = within > 8192u;                    // second half of the quadrant: use the complement
  const uint32_t o = upper ? 16384u - within : within;  // 0..8192 (eighth turn = 8192)
  const double a = double(o) * (kPi / 32768.0);
  double s, c;
  sincos_small(a, s, c);
  if (upper) {
    const double t = s;
    s = c;
    c = t;
  }
  int32_t cq = round_q15(c), sq = round_q15(s);
  // Rotate the first-quadrant pair into its quadrant exactly (integer swaps and negations).
  switch (quadrant) {
    case 0:
      cos_q15 = cq;
      sin_q15 = sq;
      break;
    case 1:
      cos_q15 = -sq;
      sin_q15 = cq;
      break;
    case 2:
      cos_q15 = -cq;
      sin_q15 = -sq;
      break;
    default:
      cos_q15 = sq;
      sin_q15 = -cq;
      break;
  }
}

uint32_t isqrt32(uint32_t v) {
  // sqrt is correctly rounded (IEEE-754), and for v < 2^52 its truncation is already the
  // exact integer floor; the corrections document the contract rather than fire.
  uint64_t r = uint64_t(std::sqrt(double(v)));
  while (r * r > v) --r;
  while ((r + 1) * (r + 1) <= v) ++r;
  return uint32_t(r);
}

int32_t reduction_shift(int64_t extent_q8) {
  int32_t s = 0;
  while ((extent_q8 >> s) >= (int64_t(1) << kReducedBits)) ++s;
  return s;
}

}  // namespace loam
