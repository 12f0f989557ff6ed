// Shockwave stamps: the integer leapfrog at the Courant cap, step splitting above it, and
// the growing box against an unbounded simulation.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>

#include "protocol/stamps/shockwave.h"
#include "protocol/stamps/stamp_apply.h"
#include "stamps_test_util.h"

namespace loam {
namespace {

using stamps_test::corner_world_params;
using stamps_test::layer_array;
using stamps_test::make_params;
using stamps_test::must_validate;

int32_t max_abs(const WaveField& f) {
  int32_t m = 0;
  for (const int32_t v : f.cur) m = std::max(m, std::abs(v));
  return m;
}

// Pins the stability limit: an integer leapfrog with nu^2 = 1/2 grows its checkerboard mode
// without bound; at the cap (0.49) and without damping it stays bounded for 100,000 steps.
TEST(Shockwave, WaveAtTheCourantCapStaysBoundedOverOneHundredThousandSteps) {
  WaveField f(24, 24);
  for (int64_t y = 0; y < 24; ++y) {
    for (int64_t x = 0; x < 24; ++x) {
      // A pulse plus a checkerboard: the mode that blows up first.
      const int32_t v = ((x + y) % 2 == 0 ? 1000 : -1000) + (x == 12 && y == 12 ? 50000 : 0);
      f.at(f.cur, x, y) = v;
      f.at(f.prev, x, y) = v;
    }
  }
  const int32_t start = max_abs(f);
  int32_t peak = 0;
  for (int i = 0; i < 100000; ++i) {
    wave_step(f, RectI{0, 0, 24, 24}, kWaveNu2CapQ16, 0);
    if (i % 97 == 0) peak = std::max(peak, max_abs(f));
  }
  peak = std::max(peak, max_abs(f));
  EXPECT_LT(peak, 4 * start) << "start " << start << " peak " << peak;
}

TEST(Shockwave, RequestedStepAboveTheCapIsSplitIntoSubSteps) {
  EXPECT_EQ(shockwave_substeps(uint16_t(0.5 * 65536)), 1);
  EXPECT_EQ(shockwave_substeps(uint16_t(0.7 * 65536)), 1);   // nu^2 = 0.49
  EXPECT_EQ(shockwave_substeps(uint16_t(0.71 * 65536)), 2);  // nu^2 = 0.504
  EXPECT_EQ(shockwave_substeps(65535), 2);
  for (uint32_t s = 1; s < 65536; s += 131) {
    const int32_t k = shockwave_substeps(uint16_t(s));
    EXPECT_LE(shockwave_nu2_q16(uint16_t(s), k), kWaveNu2CapQ16) << s;
  }
}

// The box that grows one cell per (sub-)step must give exactly the unbounded simulation: run
// the same pulse on a fixed big field, all cells every step, and compare.
void expect_equals_fixed_field(double speed, uint32_t steps, int32_t substeps) {
  World w(corner_world_params(), 32768);
  StampParams s = make_params(StampKind::kShockwave, 0.0, 0.0, 5.0, 3.0);
  s.speed = speed;
  s.damping = 0.02;
  s.steps = steps;
  const QuantizedStamp q = must_validate(s, w.params());
  ASSERT_EQ(shockwave_substeps(q.speed), substeps);
  ASSERT_TRUE(apply_stamp(w, q).ok());
  // Fixed field of 140 x 140 around the center, all cells updated every step.
  auto baked = bake_stamp(q, w.params());
  ASSERT_TRUE(baked.ok());
  const int64_t n = 140, o = -70;
  WaveField f(n, n);
  for (int64_t y = 0; y < n; ++y) {
    for (int64_t x = 0; x < n; ++x) {
      const int32_t u = radial_u_q16(baked.value(), x + o, y + o);
      if (u < 0) continue;
      f.at(f.cur, x, y) = table_lookup(baked.value().table, u);
      f.at(f.prev, x, y) = f.at(f.cur, x, y);
    }
  }
  const int32_t nu2 = shockwave_nu2_q16(q.speed, substeps);
  for (uint32_t i = 0; i < steps * uint32_t(substeps); ++i) wave_step(f, RectI{0, 0, n, n}, nu2, q.damping);
  int64_t nonzero = 0;
  for (int64_t y = 0; y < n; ++y) {
    for (int64_t x = 0; x < n; ++x) {
      const int32_t expect = std::clamp(32768 + round_q8(f.get(x, y)), 0, 65535);
      ASSERT_EQ(int32_t(w.coarse(x + o, y + o)), expect) << x + o << "," << y + o;
      if (expect != 32768) ++nonzero;
    }
  }
  EXPECT_GT(nonzero, 500);
}

TEST(Shockwave, GrowingBoxEqualsAFixedFieldSimulation) { expect_equals_fixed_field(0.6, 30, 1); }

TEST(Shockwave, SplitStepAboveTheCapEqualsTwiceTheStepsAtHalfTheSpeed) {
  expect_equals_fixed_field(0.95, 20, 2);
}

TEST(Shockwave, AcrossTheFourTileCornerOnBothLayersIsDeterministicAndSaturates) {
  for (const Layer layer : {Layer::kCoarse, Layer::kDetail}) {
    StampParams s =
        make_params(StampKind::kShockwave, 0.1, -0.2, 3.0, layer == Layer::kCoarse ? 1000.0 : 1.2);
    s.layer = layer;
    s.speed = 0.69;
    s.steps = 1;
    World a(corner_world_params(), 60000), b(corner_world_params(), 60000);
    const QuantizedStamp q = must_validate(s, a.params());
    ASSERT_TRUE(apply_stamp(a, q).ok());
    ASSERT_TRUE(apply_stamp(b, q).ok());
    a.commit(1);
    b.commit(1);
    EXPECT_EQ(a.world_hash(), b.world_hash());
    const auto v = layer_array(a, layer);
    EXPECT_EQ(*std::max_element(v.begin(), v.end()), layer_max(layer));  // saturated, not wrapped
  }
}

}  // namespace
}  // namespace loam
