// The CPU reference of every stamp kind: analytic values, symmetry, seams, saturation,
// determinism, and the validation that guards it.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "protocol/stamps/stamp_apply.h"
#include "stamps_test_util.h"
#include "tests/determinism/stamp_sequence.h"

namespace loam {
namespace {

using stamps_test::contiguous_reference;
using stamps_test::corner_world_params;
using stamps_test::layer_array;
using stamps_test::make_params;
using stamps_test::must_validate;

constexpr uint16_t kMid = 32768;

// Value change of coarse sample (x, y) after applying s to a flat world at kMid.
int32_t coarse_after(const StampParams& s, int64_t x, int64_t y, const TextureRegistry* reg = nullptr) {
  World w(corner_world_params(), kMid);
  const auto r = apply_stamp(w, must_validate(s, w.params(), reg), reg);
  EXPECT_TRUE(r.ok());
  return int32_t(w.coarse(x, y)) - kMid;
}

// ---------------------------------------------------------------- validation and quantization

TEST(StampValidation, EveryInvalidParameterIsRejectedNamingItsFieldAndTheWorldIsUnchanged) {
  World w(corner_world_params(), kMid);
  const uint64_t before = w.world_hash();
  TextureRegistry reg;
  struct Case {
    std::string field;
    std::function<void(StampParams&)> mutate;
  };
  const double nan = std::nan("");
  const double inf = INFINITY;
  const std::vector<Case> cases = {
      {"stamp.kind", [](StampParams& s) { s.kind = StampKind(6); }},
      {"stamp.layer", [](StampParams& s) { s.layer = Layer(2); }},
      {"stamp.blend", [](StampParams& s) { s.blend = BlendMode(4); }},
      {"stamp.center_x", [&](StampParams& s) { s.center_x = nan; }},
      {"stamp.center_y", [&](StampParams& s) { s.center_y = inf; }},
      {"stamp.radius", [&](StampParams& s) { s.radius = nan; }},
      {"stamp.rotation", [&](StampParams& s) { s.rotation = -inf; }},
      {"stamp.intensity", [&](StampParams& s) { s.intensity = nan; }},
      {"stamp.target", [&](StampParams& s) { s.target = nan; }},
      {"stamp.shape", [&](StampParams& s) { s.shape = nan; }},
      {"stamp.damping", [&](StampParams& s) { s.damping = inf; }},
      {"stamp.speed", [&](StampParams& s) { s.speed = nan; }},
      {"stamp.radius", [](StampParams& s) { s.radius = 0.0; }},
      {"stamp.radius", [](StampParams& s) { s.radius = -3.0; }},
      {"stamp.radius", [](StampParams& s) { s.radius = 5000.0; }},
      {"stamp.center_x", [](StampParams& s) { s.center_x = 256.0; }},
      {"stamp.center_x", [](StampParams& s) { s.center_x = -256.5; }},
      {"stamp.center_y", [](StampParams& s) { s.center_y = 1e300; }},
      {"stamp.intensity", [](StampParams& s) { s.intensity = 2000.0; }},  // > 65535 / 64 m
      {"stamp.texture_id",
       [](StampParams& s) {
         s.kind = StampKind::kTexture;
         s.texture_id = 1234;
       }},
      {"stamp.intensity",
       [](StampParams& s) {
         s.kind = StampKind::kFlatten;
         s.intensity = 1.5;
       }},
      {"stamp.intensity",
       [](StampParams& s) {
         s.kind = StampKind::kFootprint;
         s.intensity = -1.0;
       }},
      {"stamp.shape",
       [](StampParams& s) {
         s.kind = StampKind::kCrater;
         s.shape = 1.5;
       }},
      {"stamp.damping",
       [](StampParams& s) {
         s.kind = StampKind::kShockwave;
         s.steps = 10;
         s.damping = -0.1;
       }},
      {"stamp.speed",
       [](StampParams& s) {
         s.kind = StampKind::kShockwave;
         s.steps = 10;
         s.speed = 1.0;
       }},
      {"stamp.steps",
       [](StampParams& s) {
         s.kind = StampKind::kShockwave;
         s.steps = 0;
       }},
      {"stamp.steps",
       [](StampParams& s) {
         s.kind = StampKind::kShockwave;
         s.steps = 100000;
       }},
      {"stamp.volume_conserving", [](StampParams& s) { s.volume_conserving = true; }},
      {"stamp.blend",
       [](StampParams& s) {
         s.kind = StampKind::kFootprint;
         s.blend = BlendMode::kMin;
       }},
      {"stamp.target",
       [](StampParams& s) {
         s.blend = BlendMode::kMax;
         s.target = 5000.0;  // above 65535 / 64 m
       }},
      {"stamp.intensity",
       [](StampParams& s) {
         s.layer = Layer::kDetail;
         s.intensity = 2.0;  // > 255 * 0.005 m
       }},
  };
  for (const Case& c : cases) {
    StampParams s = make_params(StampKind::kGaussian, 1.0, 2.0, 10.0, 1.0);
    c.mutate(s);
    const auto q = validate_stamp(s, w.params(), {}, &reg);
    ASSERT_FALSE(q.ok()) << c.field;
    EXPECT_EQ(q.error().field, c.field) << q.error().describe();
    EXPECT_FALSE(q.error().message.empty());
  }
  // A quantized stamp from the wire is re-checked before it touches anything.
  QuantizedStamp bad = must_validate(make_params(StampKind::kGaussian, 1.0, 2.0, 10.0, 1.0), w.params());
  bad.center_x = int64_t(300) * 256;
  EXPECT_FALSE(apply_stamp(w, bad).ok());
  bad = must_validate(make_params(StampKind::kGaussian, 1.0, 2.0, 10.0, 1.0), w.params());
  bad.kind = StampKind(17);
  EXPECT_FALSE(apply_stamp(w, bad).ok());
  EXPECT_FALSE(w.has_pending());
  w.commit(1);
  EXPECT_EQ(w.world_hash(), before);
}

// docs/stamps.md: the target height belongs to flatten and the min/max blends, "else 0". A
// gaussian (or crater, footprint, shockwave, texture) with the add or subtract blend and a
// target used to pass and quietly drop it; now it is refused, naming the field, in both forms.
TEST(StampValidation, GaussianWithTargetIsRejected) {
  const WorldParams wp = corner_world_params();
  StampParams s = make_params(StampKind::kGaussian, 1.0, 2.0, 10.0, 1.0);
  s.target = 12.5;
  const auto q = validate_stamp(s, wp);
  ASSERT_FALSE(q.ok());
  EXPECT_EQ(q.error().field, "stamp.target");
  EXPECT_NE(q.error().message.find("gaussian"), std::string::npos) << q.error().describe();
  s.blend = BlendMode::kSubtract;
  EXPECT_EQ(validate_stamp(s, wp).error().field, "stamp.target");
  for (const StampKind kind : {StampKind::kCrater, StampKind::kFootprint, StampKind::kShockwave}) {
    StampParams k = make_params(kind, 1.0, 2.0, 6.0, 0.5);
    k.steps = 4;
    k.target = -3.0;
    const auto r = validate_stamp(k, wp);
    ASSERT_FALSE(r.ok()) << to_string(kind);
    EXPECT_EQ(r.error().field, "stamp.target") << r.error().describe();
  }
  // Where a target means something it is still taken.
  s.blend = BlendMode::kMax;
  EXPECT_TRUE(validate_stamp(s, wp).ok());
  StampParams flatten = make_params(StampKind::kFlatten, 1.0, 2.0, 10.0, 0.5);
  flatten.target = 12.5;
  EXPECT_TRUE(validate_stamp(flatten, wp).ok());
}

// The same rule on a quantized stamp from the wire or the log (crafted past validate_stamp).
TEST(StampValidation, QuantizedGaussianWithTargetIsRejected) {
  World w(corner_world_params(), kMid);
  QuantizedStamp q = must_validate(make_params(StampKind::kGaussian, 1.0, 2.0, 10.0, 1.0), w.params());
  q.target = 100;
  const Status st = check_quantized(q, w.params());
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().field, "stamp.target");
  EXPECT_FALSE(apply_stamp(w, q).ok());
  EXPECT_FALSE(w.has_pending());
  q.blend = BlendMode::kMin;
  EXPECT_TRUE(check_quantized(q, w.params()).ok());
}

// docs/stamps.md: shape belongs to crater, footprint and flatten, damping/speed/steps to the
// shockwave, texture_id to texture stamps. validate_stamp sets them only there; a quantized
// stamp from the wire or the log that carries one elsewhere is refused, naming the field.
TEST(StampValidation, QuantizedFieldsOfOtherKindsAreRejected) {
  const WorldParams wp = corner_world_params();
  const QuantizedStamp gaussian = must_validate(make_params(StampKind::kGaussian, 1.0, 2.0, 10.0, 1.0), wp);
  struct Case {
    const char* field;
    void (*mutate)(QuantizedStamp&);
  };
  const Case cases[] = {
      {"stamp.shape", [](QuantizedStamp& q) { q.shape = 100; }},
      {"stamp.damping", [](QuantizedStamp& q) { q.damping = 100; }},
      {"stamp.speed", [](QuantizedStamp& q) { q.speed = 100; }},
      {"stamp.steps", [](QuantizedStamp& q) { q.steps = 3; }},
      {"stamp.texture_id", [](QuantizedStamp& q) { q.texture_id = 42; }},
  };
  for (const Case& c : cases) {
    QuantizedStamp q = gaussian;
    c.mutate(q);
    const Status st = check_quantized(q, wp);
    ASSERT_FALSE(st.ok()) << c.field;
    EXPECT_EQ(st.error().field, c.field) << st.error().describe();
  }
  // A crater keeps its shape.
  StampParams crater = make_params(StampKind::kCrater, 1.0, 2.0, 10.0, 1.0);
  crater.shape = 0.3;
  EXPECT_TRUE(check_quantized(must_validate(crater, wp), wp).ok());
}

TEST(StampValidation, AcceptedParametersAreQuantizedToTheDocumentedFixedPoint) {
  const WorldParams wp = corner_world_params();
  StampParams s = make_params(StampKind::kGaussian, 10.25, -3.5, 7.125, 1.0);
  s.rotation = 3.141592653589793 / 2.0;
  const QuantizedStamp q = must_validate(s, wp);
  EXPECT_EQ(q.center_x, 10 * 256 + 64);
  EXPECT_EQ(q.center_y, -3 * 256 - 128);
  EXPECT_EQ(q.radius, 7u * 256u + 32u);
  EXPECT_EQ(q.rotation, 16384);
  EXPECT_EQ(q.intensity, 64 * 256);  // 1 m at 1/64 m per unit, Q8
  // Detail layer: 4 samples per meter, 0.005 m per unit.
  s.layer = Layer::kDetail;
  s.intensity = 0.1;
  const QuantizedStamp d = must_validate(s, wp);
  EXPECT_EQ(d.center_x, 41 * 256);
  EXPECT_EQ(d.radius, 28u * 256u + 128u);
  EXPECT_EQ(d.intensity, 20 * 256);
  // A radius far below one sample still quantizes to a positive radius.
  s.radius = 1e-9;
  EXPECT_EQ(must_validate(s, wp).radius, 1u);
}

// ---------------------------------------------------------------- analytic values

TEST(StampGaussian, ValuesMatchTheAnalyticProfileAtChosenPoints) {
  const double a_units = 640.0;  // 10 m
  const StampParams s = make_params(StampKind::kGaussian, 0.0, 0.0, 64.0, 10.0);
  World w(corner_world_params(), kMid);
  ASSERT_TRUE(apply_stamp(w, must_validate(s, w.params())).ok());
  EXPECT_EQ(int32_t(w.coarse(0, 0)) - kMid, 640);
  for (const auto& [x, y] :
       std::vector<std::pair<int, int>>{{16, 0}, {32, 0}, {0, -48}, {30, 30}, {-20, 11}}) {
    const double u = std::sqrt(double(x * x + y * y)) / 64.0;
    const double expect = a_units * std::exp(-12.0 * u * u);
    EXPECT_NEAR(int32_t(w.coarse(x, y)) - kMid, expect, 0.75) << x << "," << y;
  }
  // Below half a unit at the support's edge and beyond: nothing changes there.
  EXPECT_EQ(w.coarse(64, 0), kMid);
  EXPECT_EQ(w.coarse(63, 0), kMid);
}

TEST(StampGaussian, LargestAmplitudeRoundsToZeroAtTheEdgeSoItIsNeverTruncated) {
  World w(corner_world_params(), 0);
  const StampParams s = make_params(StampKind::kGaussian, 0.0, 0.0, 100.0, 65535.0 / 64.0);
  ASSERT_TRUE(apply_stamp(w, must_validate(s, w.params())).ok());
  EXPECT_EQ(w.coarse(0, 0), 65535);
  // Just inside the support the profile is below one unit already.
  EXPECT_LE(w.coarse(99, 0), 1);
  EXPECT_EQ(w.coarse(100, 0), 0);
}

TEST(StampCrater, BowlBottomIsTheDepthAndTheRimCrestIsShapeTimesDepth) {
  StampParams s = make_params(StampKind::kCrater, 0.0, 0.0, 80.0, 4.0);  // 256 units deep
  s.shape = 0.5;
  EXPECT_EQ(coarse_after(s, 0, 0), -256);
  EXPECT_NEAR(coarse_after(s, 50, 0), 128, 1);  // crest at u = 5/8
  EXPECT_NEAR(coarse_after(s, 25, 0), -256 * (1.0 - 0.25) + 128 * 0.0625, 1);
  const double t = (70.0 / 80.0 - 0.625) / 0.375;
  EXPECT_NEAR(coarse_after(s, 0, 70), 128 * (1 - t) * (1 - t) * (1 + 2 * t), 1);
  EXPECT_EQ(coarse_after(s, 80, 0), 0);
}

TEST(StampCrater, VolumeConservingCraterMovesTheDugMaterialIntoTheRimWithinRounding) {
  for (const double radius : {12.3, 40.0, 97.5}) {
    StampParams s = make_params(StampKind::kCrater, 3.3, -7.6, radius, 6.0);
    s.shape = 0.3;
    s.volume_conserving = true;
    World w(corner_world_params(), kMid);
    const auto before = layer_array(w, Layer::kCoarse);
    ASSERT_TRUE(apply_stamp(w, must_validate(s, w.params())).ok());
    const auto after = layer_array(w, Layer::kCoarse);
    int64_t net = 0, dug = 0, changed = 0;
    for (size_t i = 0; i < before.size(); ++i) {
      const int64_t d = after[i] - before[i];
      net += d;
      if (d < 0) dug -= d;
      if (d != 0) ++changed;
    }
    EXPECT_GT(dug, 0);
    // Each sample rounds by at most half a unit (plus the table's rounding).
    EXPECT_LE(std::abs(net), changed / 2 + 1) << "radius " << radius << " dug " << dug;
    EXPECT_LT(double(std::abs(net)), 0.01 * double(dug)) << "radius " << radius;
  }
}

TEST(StampFootprint, PressesFromTheFirstContactSoANarrowPeakIsDentedNotItsSlopes) {
  World w(corner_world_params(), kMid);
  // A one-sample spike 1000 units high with a 300-unit shoulder around it.
  std::vector<uint16_t> block(9, uint16_t(kMid + 300));
  block[4] = uint16_t(kMid + 1000);
  w.write_coarse(RectI{-1, -1, 2, 2}, block);
  w.commit(0);
  const StampParams s = make_params(StampKind::kFootprint, 0.0, 0.0, 6.0, 100.0 / 64.0);  // 100 units
  ASSERT_TRUE(apply_stamp(w, must_validate(s, w.params())).ok());
  EXPECT_EQ(w.coarse(0, 0), kMid + 900);  // contact at the peak, pressed 100 units
  EXPECT_EQ(w.coarse(1, 0), kMid + 300);  // the shoulder is below the sole: untouched
  EXPECT_EQ(w.coarse(4, 0), kMid);
}

TEST(StampFootprint, CurvedSoleFollowsContactMinusDepthPlusShape) {
  StampParams s = make_params(StampKind::kFootprint, 0.0, 0.0, 20.0, 200.0 / 64.0);
  s.shape = 0.5;
  // Flat ground: contact at the ground, new = min(old, old - 200 + 100 u^2).
  EXPECT_EQ(coarse_after(s, 0, 0), -200);
  EXPECT_NEAR(coarse_after(s, 10, 0), -200 + 100 * 0.25, 1);
  EXPECT_EQ(coarse_after(s, 20, 0), 0);
}

TEST(StampFlatten, PullsFullyToTheTargetInsideAndBlendsOverTheSoftEdge) {
  StampParams s = make_params(StampKind::kFlatten, 0.0, 0.0, 40.0, 1.0);
  s.shape = 0.5;
  s.target = (kMid - 640) / 64.0;
  EXPECT_EQ(coarse_after(s, 0, 0), -640);
  EXPECT_EQ(coarse_after(s, 19, 0), -640);
  EXPECT_NEAR(coarse_after(s, 30, 0), -320, 2);  // smoothstep half-way through the edge
  EXPECT_EQ(coarse_after(s, 40, 0), 0);
  s.intensity = 0.25;  // strength
  EXPECT_EQ(coarse_after(s, 0, 0), -160);
}

TEST(StampBlend, MinAndMaxCompareWithTargetPlusProfileAndAddSubtractAreExactInverses) {
  StampParams s = make_params(StampKind::kGaussian, 0.0, 0.0, 30.0, 1.0);  // 64 units
  s.blend = BlendMode::kMax;
  s.target = (kMid + 10) / 64.0;
  EXPECT_EQ(coarse_after(s, 0, 0), 74);  // max(old, target + 64)
  s.blend = BlendMode::kMin;
  EXPECT_EQ(coarse_after(s, 0, 0), 0);  // old is below target + 64
  s.target = (kMid - 100) / 64.0;
  EXPECT_EQ(coarse_after(s, 0, 0), -36);
  s.blend = BlendMode::kSubtract;
  s.target = 0.0;  // add and subtract take no target
  EXPECT_EQ(coarse_after(s, 0, 0), -64);
}

// A 4x2 image: left half black, right half white.
uint64_t register_half_image(TextureRegistry& reg) {
  const std::vector<uint16_t> img = {0, 0, 65535, 65535, 0, 0, 65535, 65535};
  return reg.add(4, 2, img).value();
}

TEST(StampTexture, BilinearSamplesOfTheScaledImageAtChosenPoints) {
  TextureRegistry reg;
  StampParams s = make_params(StampKind::kTexture, 0.0, 0.0, 32.0, 4.0);  // 256 units
  s.texture_id = register_half_image(reg);
  // Image x = (u + 32) / 64 * 4 - 0.5; the black-white step is between pixel 1 and 2,
  // i.e. image x in [1, 2] <-> stamp x in [-8, 8], linear in between.
  EXPECT_EQ(coarse_after(s, -20, 0, &reg), 0);
  EXPECT_EQ(coarse_after(s, 20, 5, &reg), 256);
  EXPECT_EQ(coarse_after(s, 0, 0, &reg), 128);
  EXPECT_EQ(coarse_after(s, 4, -3, &reg), 192);
  EXPECT_EQ(coarse_after(s, 31, 31, &reg), 256);
  EXPECT_EQ(coarse_after(s, 33, 0, &reg), 0);  // outside the square
  // A quarter turn counter-clockwise puts white on +y.
  s.rotation = 3.141592653589793 / 2.0;
  EXPECT_EQ(coarse_after(s, 0, 20, &reg), 256);
  EXPECT_EQ(coarse_after(s, 0, -20, &reg), 0);
  // An eighth turn: the rotated square reaches radius * sqrt(2) along the axes.
  s.rotation = 3.141592653589793 / 4.0;
  EXPECT_EQ(coarse_after(s, 40, 0, &reg), 256);
}

TEST(StampTexture, ContentIdIsTheHashOfTheImageAndReRegisteringIsIdempotent) {
  TextureRegistry reg;
  const uint64_t a = register_half_image(reg);
  EXPECT_EQ(register_half_image(reg), a);
  EXPECT_EQ(reg.size(), 1u);
  const std::vector<uint16_t> other = {0, 0, 65535, 65534, 0, 0, 65535, 65535};
  EXPECT_NE(reg.add(4, 2, other).value(), a);
  EXPECT_FALSE(reg.add(0, 2, {}).ok());
  EXPECT_FALSE(reg.add(4, 3, other).ok());
}

// ---------------------------------------------------------------- symmetry and exactness

TEST(StampRadialKinds, AreExactlySymmetricUnderQuarterTurnsAndMirrors) {
  for (const StampKind kind :
       {StampKind::kGaussian, StampKind::kCrater, StampKind::kFlatten, StampKind::kFootprint}) {
    for (const double radius : {9.7, 60.0, 230.0}) {  // reduction shift 0, 0 and 2
      StampParams s = make_params(kind, 0.0, 0.0, radius, kind == StampKind::kFlatten ? 1.0 : 5.0);
      s.shape = 0.4;
      if (kind == StampKind::kFlatten) s.target = (kMid + 500) / 64.0;  // the others take no target
      World w(corner_world_params(), kMid);
      ASSERT_TRUE(apply_stamp(w, must_validate(s, w.params())).ok());
      const int64_t n = std::min<int64_t>(int64_t(radius) + 2, 255);
      for (int64_t y = -n; y <= n; ++y) {
        for (int64_t x = -n; x <= n; ++x) {
          const uint16_t v = w.coarse(x, y);
          ASSERT_EQ(v, w.coarse(-y, x)) << to_string(kind) << " r " << radius << " at " << x << "," << y;
          ASSERT_EQ(v, w.coarse(-x, -y));
          ASSERT_EQ(v, w.coarse(y, x));
        }
      }
    }
  }
}

TEST(StampProfile, OwnExpAndRotationTablesMatchLibmClosely) {
  for (double x = 0.0; x <= 30.0; x += 0.37) {
    EXPECT_NEAR(exact_exp_neg(x) / std::exp(-x), 1.0, 1e-12) << x;
  }
  for (uint32_t r = 0; r < 65536; r += 97) {
    int32_t c, s;
    rotation_q15(uint16_t(r), c, s);
    const double a = double(r) / 65536.0 * 6.283185307179586;
    EXPECT_LE(std::abs(c - std::lround(std::cos(a) * 32768.0)), 1);
    EXPECT_LE(std::abs(s - std::lround(std::sin(a) * 32768.0)), 1);
  }
  int32_t c, s;
  rotation_q15(16384, c, s);
  EXPECT_EQ(c, 0);
  EXPECT_EQ(s, 32768);
  // Exact floor around every perfect square up to 2^29 (the kernel's range) and at the top.
  for (uint64_t n = 0; n <= 23170; n += 1) {
    for (const int64_t off : {-1, 0, 1}) {
      const int64_t v = int64_t(n * n) + off;
      if (v < 0) continue;
      const uint64_t r = isqrt32(uint32_t(v));
      ASSERT_LE(r * r, uint64_t(v));
      ASSERT_GT((r + 1) * (r + 1), uint64_t(v));
    }
  }
  EXPECT_EQ(isqrt32(0xFFFFFFFFu), 65535u);
}

TEST(StampBitBudget, ReducedOffsetsStayBelowTwoToTheFourteenAtTheHardMaximumRadius) {
  // Texture has the largest support (radius * sqrt 2); check the four extreme offsets.
  const int64_t radius_q8 = int64_t(kHardMaxRadiusSamples) * 256;
  const int64_t support = (radius_q8 * 46341 + 32767) / 32768 + 1;
  const int32_t s = reduction_shift(support);
  for (const int64_t d : {-support, support, -support + 1, support - 1}) {
    EXPECT_LT(std::abs(reduce(d, s)), 1 << kReducedBits);
  }
  EXPECT_LT(support, int64_t(1) << 31);  // stamp-relative Q8 offsets fit int32
  const int64_t r = reduce(support, s);
  EXPECT_LT(2 * r * r, int64_t(1) << 29);  // squared distance fits int32
}

// ---------------------------------------------------------------- degenerate sizes

TEST(StampDegenerateSize, RadiusBelowOneSampleChangesAtMostTheSampleUnderIt) {
  World w(corner_world_params(), kMid);
  const auto r =
      apply_stamp(w, must_validate(make_params(StampKind::kGaussian, 5.0, 5.0, 0.3, 1.0), w.params()));
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r.value(), (RectI{5, 5, 6, 6}));
  EXPECT_EQ(w.coarse(5, 5), kMid + 64);
  // Between samples it reaches none: nothing changes, nothing is marked.
  World w2(corner_world_params(), kMid);
  const auto r2 =
      apply_stamp(w2, must_validate(make_params(StampKind::kCrater, 5.5, 5.5, 0.3, 1.0), w2.params()));
  ASSERT_TRUE(r2.ok());
  EXPECT_TRUE(r2.value().empty());
  EXPECT_FALSE(w2.has_pending());
  // Every kind survives a sub-sample radius.
  for (int k = 0; k < kStampKindCount; ++k) {
    TextureRegistry reg;
    StampParams s = make_params(StampKind(k), 5.0, 5.0, 0.2, 0.5);
    s.texture_id = register_half_image(reg);
    s.steps = 3;
    ASSERT_TRUE(apply_stamp(w, must_validate(s, w.params(), &reg), &reg).ok()) << k;
  }
}

TEST(StampDegenerateSize, MaximumRadiusStampCoversTheWorldAndMatchesContiguous) {
  StampLimits lim;
  lim.max_radius_samples = 4096;
  World w(corner_world_params(), kMid);
  StampParams s = make_params(StampKind::kGaussian, -100.0, 50.0, 4096.0, 3.0);
  const QuantizedStamp q = must_validate(s, w.params(), nullptr, lim);
  const auto expect = contiguous_reference(w, q);
  const auto r = apply_stamp(w, q, nullptr, lim);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r.value(), w.params().sample_rect());
  EXPECT_EQ(layer_array(w, Layer::kCoarse), expect);
}

// ---------------------------------------------------------------- seams

void expect_matches_contiguous(const StampParams& s, const char* what) {
  TextureRegistry reg;
  StampParams p = s;
  if (p.kind == StampKind::kTexture) p.texture_id = register_half_image(reg);
  World w(corner_world_params(), kMid);
  // Non-flat terrain so footprint and flatten see different old values on each side.
  std::vector<uint16_t> ramp(size_t(512 * 512));
  for (int64_t i = 0; i < int64_t(ramp.size()); ++i)
    ramp[size_t(i)] = uint16_t(kMid + (i % 512) * 3 - (i / 512) * 2);
  w.write_coarse(w.params().sample_rect(), ramp);
  w.commit(0);
  const QuantizedStamp q = must_validate(p, w.params(), &reg);
  const auto expect = contiguous_reference(w, q, &reg);
  const auto r = apply_stamp(w, q, &reg);
  ASSERT_TRUE(r.ok());
  EXPECT_FALSE(r.value().empty()) << what;
  const auto got = layer_array(w, p.layer);
  const RectI lr = layer_sample_rect(w.params(), p.layer);
  int64_t mismatches = 0;
  for (size_t i = 0; i < got.size(); ++i) {
    if (got[i] != expect[i] && mismatches++ < 3) {
      ADD_FAILURE() << what << " " << to_string(p.kind) << " " << to_string(p.layer) << " at "
                    << lr.x0 + int64_t(i) % lr.width() << "," << lr.y0 + int64_t(i) / lr.width() << ": "
                    << got[i] << " != " << expect[i];
    }
  }
  EXPECT_EQ(mismatches, 0);
}

TEST(StampSeams, StampAcrossTileBorderMatchesContiguous) {
  for (const Layer layer : {Layer::kCoarse, Layer::kDetail}) {
    for (int k = 0; k < kStampKindCount - 1; ++k) {
      StampParams s =
          make_params(StampKind(k), 0.3, 100.0, 17.0, StampKind(k) == StampKind::kFlatten ? 1.0 : 0.5);
      s.layer = layer;
      s.shape = 0.5;
      if (StampKind(k) == StampKind::kFlatten) s.target = layer == Layer::kCoarse ? 400.0 : 0.2;
      s.rotation = 0.7;
      expect_matches_contiguous(s, "border");
    }
  }
}

TEST(StampSeams, StampAcrossFourTileCornerMatchesContiguous) {
  for (const Layer layer : {Layer::kCoarse, Layer::kDetail}) {
    for (int k = 0; k < kStampKindCount - 1; ++k) {
      for (const double c : {0.0, -0.6, 0.25}) {
        StampParams s =
            make_params(StampKind(k), c, -c, 9.5, StampKind(k) == StampKind::kFlatten ? 0.8 : -0.4);
        if (StampKind(k) == StampKind::kFootprint) s.intensity = 0.4;
        s.layer = layer;
        s.shape = 0.7;
        if (StampKind(k) == StampKind::kFlatten) s.target = layer == Layer::kCoarse ? 600.0 : -0.1;
        s.rotation = -2.1;
        s.volume_conserving = StampKind(k) == StampKind::kCrater;
        expect_matches_contiguous(s, "corner");
      }
    }
  }
}

TEST(StampSeams, CommitUpdatesMipsHashesAndVersionsOfExactlyTheTouchedTiles) {
  World w(corner_world_params(), kMid);
  const uint64_t h0 = w.tile_state({Layer::kCoarse, 0, 0, 0}).hash;
  const auto r =
      apply_stamp(w, must_validate(make_params(StampKind::kCrater, 0.0, 0.0, 12.0, 2.0), w.params()));
  ASSERT_TRUE(r.ok());
  const auto changes = w.commit(7);
  for (int ty = -1; ty <= 0; ++ty) {
    for (int tx = -1; tx <= 0; ++tx) {
      const TileState st = w.tile_state({Layer::kCoarse, 0, tx, ty});
      EXPECT_EQ(st.version, 7u);
      EXPECT_NE(st.hash, h0);
    }
  }
  // Mip 1 holds every second sample.
  const auto m1 = w.coarse_tile(1, -1, -1);
  ASSERT_FALSE(m1.empty());
  for (int64_t j = 240; j < 256; ++j) {
    for (int64_t i = 240; i < 256; ++i) {
      const int64_t gx = (-256 + i) * 2, gy = (-256 + j) * 2;
      EXPECT_EQ(m1[size_t(j * kTileSize + i)], w.coarse(gx, gy));
    }
  }
  EXPECT_FALSE(changes.empty());
}

TEST(StampSeams, DetailTilesAreCreatedOnlyWhereASampleChanges) {
  World w(corner_world_params(), kMid);
  StampParams s = make_params(StampKind::kGaussian, 10.0, 10.0, 5.0, 0.2);
  s.layer = Layer::kDetail;
  ASSERT_TRUE(apply_stamp(w, must_validate(s, w.params())).ok());
  EXPECT_EQ(w.detail_tile_count(), 1u);
  s.intensity = 0.0;
  ASSERT_TRUE(apply_stamp(w, must_validate(s, w.params())).ok());
  EXPECT_EQ(w.detail_tile_count(), 1u);
}

// ---------------------------------------------------------------- saturation and determinism

TEST(StampSaturation, TenThousandDigsAndRaisesSaturateWithoutWrapAround) {
  for (const Layer layer : {Layer::kCoarse, Layer::kDetail}) {
    World w(corner_world_params(), kMid);
    StampParams s = make_params(StampKind::kGaussian, 0.0, 0.0, 3.0, layer == Layer::kCoarse ? 3.0 : 0.3);
    s.layer = layer;
    const int32_t lo = layer_min(layer), hi = layer_max(layer);
    auto center = [&] { return layer == Layer::kCoarse ? int32_t(w.coarse(0, 0)) : int32_t(w.detail(0, 0)); };
    s.blend = BlendMode::kSubtract;
    const QuantizedStamp dig = must_validate(s, w.params());
    int32_t prev = center();
    for (int i = 0; i < 10000; ++i) {
      ASSERT_TRUE(apply_stamp(w, dig).ok());
      const int32_t c = center();
      ASSERT_LE(c, prev) << "wrapped at dig " << i;
      prev = c;
      if (i % 1000 == 999) w.commit(uint64_t(i));
    }
    EXPECT_EQ(center(), lo);
    s.blend = BlendMode::kAdd;
    const QuantizedStamp raise = must_validate(s, w.params());
    for (int i = 0; i < 10000; ++i) {
      ASSERT_TRUE(apply_stamp(w, raise).ok());
      const int32_t c = center();
      ASSERT_GE(c, prev) << "wrapped at raise " << i;
      prev = c;
    }
    EXPECT_EQ(center(), hi);
  }
}

TEST(StampSaturation, TenThousandAddSubtractPairsReturnToTheSameHashWithoutDrift) {
  World w(corner_world_params(), kMid);
  w.commit(0);
  const uint64_t h0 = w.world_hash();
  StampParams s = make_params(StampKind::kCrater, 0.4, -0.2, 7.0, 1.5);
  s.shape = 0.6;
  const QuantizedStamp add = must_validate(s, w.params());
  s.blend = BlendMode::kSubtract;
  const QuantizedStamp sub = must_validate(s, w.params());
  for (int i = 0; i < 10000; ++i) {
    ASSERT_TRUE(apply_stamp(w, add).ok());
    ASSERT_TRUE(apply_stamp(w, sub).ok());
  }
  w.commit(1);
  EXPECT_EQ(w.world_hash(), h0);
}

// The sequence lives in tests/determinism/ so a clang build can run it too.
uint64_t seeded_sequence_hash() {
  std::string error;
  const uint64_t h = determinism::golden_stamp_sequence_hash(&error);
  EXPECT_TRUE(error.empty()) << error;
  return h;
}

TEST(StampDeterminism, TheSameStampSequenceTwiceGivesTheSameWorldHash) {
  EXPECT_EQ(seeded_sequence_hash(), seeded_sequence_hash());
}

// The golden hash pins the table baking and the kernels: GCC and clang builds (and every
// platform) must reproduce it. If an intentional change of the stamp arithmetic moves it,
// update the constant and docs/stamps.md together.
TEST(StampDeterminism, SeededSequenceReproducesTheGoldenHashOnEveryCompiler) {
  EXPECT_EQ(seeded_sequence_hash(), determinism::kGoldenStampSequenceHash)
      << std::hex << seeded_sequence_hash();
}

// bake_stamp reuses the tables of recent profiles. Stamps whose profiles differ in one field
// each (kind, intensity by one unit, shape, volume conservation, whose rim height depends on the
// radius and the centre's sub-sample offset), baked in turn more times than the memo has slots,
// must get the table a thread that never baked anything gets.
TEST(StampProfile, AReusedTableIsBitForBitTheTableBakedAfresh) {
  const WorldParams p = corner_world_params();
  std::vector<QuantizedStamp> stamps;
  for (const StampKind kind :
       {StampKind::kGaussian, StampKind::kCrater, StampKind::kFootprint, StampKind::kFlatten}) {
    for (const double intensity : {2.0, 2.0 + 1.0 / 256.0, 40.0}) {
      StampParams s =
          make_params(kind, 3.3, -7.9, 12.0, kind == StampKind::kFlatten ? intensity / 64.0 : intensity);
      s.shape = 0.25;
      stamps.push_back(must_validate(s, p));
      s.shape = 0.5;
      stamps.push_back(must_validate(s, p));
      if (kind == StampKind::kCrater) {
        s.volume_conserving = true;
        stamps.push_back(must_validate(s, p));
        s.radius = 12.5;  // another rim height from the same depth and shape
        stamps.push_back(must_validate(s, p));
        s.center_x += 0.4;
        stamps.push_back(must_validate(s, p));
      }
    }
  }
  std::vector<ProfileTable> fresh(stamps.size());
  for (size_t i = 0; i < stamps.size(); ++i) {
    std::thread([&] {
      auto b = bake_stamp(stamps[i], p);
      ASSERT_TRUE(b.ok());
      fresh[i] = b.value().table;
    }).join();
  }
  for (int round = 0; round < 3; ++round) {
    for (size_t i = 0; i < stamps.size(); ++i) {
      const size_t k = (i * 7 + size_t(round)) % stamps.size();  // a different order each round
      auto b = bake_stamp(stamps[k], p);
      ASSERT_TRUE(b.ok());
      EXPECT_EQ(b.value().table, fresh[k]) << "stamp " << k << " round " << round;
    }
  }
}

// stamp_reach bounds what a stamp may change without applying it (the client's overlay
// decides with it which tiles a prediction needs): every changed sample of every kind, on both
// layers and across tile corners and world edges, lies inside it.
TEST(StampReach, HoldsEverySampleTheStampChanges) {
  const WorldParams w = stamps_test::corner_world_params();
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> pos(-300, 300), unit(0, 1);
  int checked = 0;
  for (int i = 0; i < 300; ++i) {
    StampParams p = stamps_test::make_params(StampKind(i % 6 == 0 ? 1 : i % 6), pos(rng), pos(rng),
                                             1 + 40 * unit(rng), 0.5 + 2 * unit(rng));
    if (p.kind == StampKind::kTexture) p.kind = StampKind::kGaussian;
    p.layer = i % 5 == 0 ? Layer::kDetail : Layer::kCoarse;
    p.shape = 0.3;
    if (p.kind == StampKind::kFlatten) p.target = 10;
    if (p.kind == StampKind::kShockwave)
      p.steps = 1 + uint32_t(30 * unit(rng)), p.speed = 0.6, p.damping = 0.1;
    if (p.layer == Layer::kDetail) p.intensity *= 0.1, p.radius *= 0.2;
    auto q = validate_stamp(p, w);
    if (!q) continue;
    World world(w, 30000);
    const auto reach = stamp_reach(*q, w);
    ASSERT_TRUE(reach.ok()) << reach.error().describe();
    const auto changed = apply_stamp(world, *q);
    ASSERT_TRUE(changed.ok());
    EXPECT_TRUE(reach->contains(*changed)) << to_string(q->kind) << " stamp " << i;
    checked += !changed->empty();
  }
  EXPECT_GT(checked, 150);
}

// stamp_cost is what admission counts: a stamp's reach in samples, times a shockwave's steps
// and sub-steps; it grows with the radius squared and linearly with the steps.
TEST(StampCost, IsTheReachTimesTheShockwavesStepsAndSubsteps) {
  const WorldParams w = stamps_test::corner_world_params();
  StampParams p = stamps_test::make_params(StampKind::kGaussian, 10, 10, 20, 1);
  auto q = validate_stamp(p, w);
  ASSERT_TRUE(q.ok());
  EXPECT_EQ(*stamp_cost(*q, w), uint64_t(stamp_reach(*q, w)->area()));
  p.radius = 40;
  const uint64_t wider = *stamp_cost(*validate_stamp(p, w), w);
  EXPECT_GT(wider, 3 * *stamp_cost(*q, w));
  p = stamps_test::make_params(StampKind::kShockwave, 10, 10, 4, 1);
  p.steps = 10;
  p.speed = 0.5;
  auto wave = validate_stamp(p, w);
  ASSERT_TRUE(wave.ok());
  const uint64_t area = uint64_t(stamp_reach(*wave, w)->area());
  EXPECT_EQ(*stamp_cost(*wave, w), area * 10 * uint64_t(shockwave_substeps(wave->speed)));
  p.speed = 0.95;  // above the Courant cap: sub-steps, each of them counted
  auto fast = validate_stamp(p, w);
  ASSERT_TRUE(fast.ok());
  ASSERT_GT(shockwave_substeps(fast->speed), 1);
  EXPECT_EQ(*stamp_cost(*fast, w),
            uint64_t(stamp_reach(*fast, w)->area()) * 10 * uint64_t(shockwave_substeps(fast->speed)));
  p.radius = std::nan("");
  EXPECT_FALSE(validate_stamp(p, w).ok());  // what never validates never reaches stamp_cost
}

}  // namespace
}  // namespace loam
