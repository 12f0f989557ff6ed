// The fast stamp kernel (stamp_fast.h) against the scalar reference (apply_stamp_reference):
// same samples, same returned rect, same dirty tiles and versions after commit, for every
// kind, layer, blend and instruction set, on seeded random stamps and on the hard cases.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_fast.h"
#include "protocol/stamps/stamp_mix.h"
#include "protocol/stamps/stamp_profile.h"
#include "stamps_test_util.h"

namespace loam {
namespace {

using stamps_test::corner_world_params;

// Deterministic draws on every platform (std distributions are not).
using Rng = StampRng;

std::vector<FastIsa> isas() {
  std::vector<FastIsa> v = {FastIsa::kBest, FastIsa::kPortable};
  if (fast_isa_available(FastIsa::kAvx2)) v.push_back(FastIsa::kAvx2);
  if (fast_isa_available(FastIsa::kAvx2Direct)) v.push_back(FastIsa::kAvx2Direct);
  return v;
}

const char* isa_name(FastIsa isa) {
  switch (isa) {
    case FastIsa::kBest: return "best";
    case FastIsa::kPortable: return "portable";
    case FastIsa::kAvx2: return "avx2";
    case FastIsa::kAvx2Direct: return "avx2 direct";
  }
  return "?";
}

// A world with rough random terrain on both layers: coarse values spread over the whole range
// (so saturation happens at both ends), some detail tiles stored and others absent.
World random_world(Rng& rng, const WorldParams& p) {
  World w(p, uint16_t(rng.range(0, 65535)));
  const RectI r = p.sample_rect();
  std::vector<uint16_t> c(size_t(r.area()));
  const int32_t mode = int32_t(rng.range(0, 2));
  for (auto& v : c) {
    // 0: anywhere; 1: near the floor; 2: near the ceiling.
    v = uint16_t(mode == 0 ? rng.range(0, 65535) : mode == 1 ? rng.range(0, 300) : rng.range(65235, 65535));
  }
  (void)w.write_coarse(r, c);
  const RectI dr = p.detail_sample_rect();
  const RectI dtiles = tiles_overlapping(dr);
  for (int64_t ty = dtiles.y0; ty < dtiles.y1; ++ty) {
    for (int64_t tx = dtiles.x0; tx < dtiles.x1; ++tx) {
      if (!rng.chance(30)) continue;
      const RectI t = tile_rect(int32_t(tx), int32_t(ty));
      std::vector<int8_t> d(size_t(t.area()));
      for (auto& v : d) v = int8_t(rng.range(-128, 127));
      (void)w.write_detail(t, d);
    }
  }
  w.commit(1);
  return w;
}

// The samples of `r` in one layer, as int32.
std::vector<int32_t> read_rect(const World& w, Layer layer, const RectI& r) {
  std::vector<int32_t> out(size_t(r.area()));
  if (layer == Layer::kCoarse) {
    std::vector<uint16_t> t(out.size());
    w.read_coarse(r, t);
    std::copy(t.begin(), t.end(), out.begin());
  } else {
    std::vector<int8_t> t(out.size());
    w.read_detail(r, t);
    std::copy(t.begin(), t.end(), out.begin());
  }
  return out;
}

// Applies q with the reference to `ref` and with every ISA to its world in `fast` (all equal to
// `ref` before); everything observable must agree: the samples of the stamp's rect one by one,
// the world hash (every other sample), the returned rect, the detail tiles created and the tiles
// commit (at `seq`) reports. Returns the number of samples the stamp changed (for coverage checks).
int64_t expect_step_matches_reference(World& ref, std::vector<World>& fast, const QuantizedStamp& q,
                                      const TextureRegistry* reg, const std::string& what,
                                      const StampLimits& limits, uint64_t seq) {
  auto baked = bake_stamp(q, ref.params(), reg);
  const RectI rect = baked.ok() ? baked.value().rect : RectI{};
  const std::vector<int32_t> before = read_rect(ref, q.layer, rect);
  const auto rr = apply_stamp_reference(ref, q, reg, limits);
  const std::vector<int32_t> ref_samples = read_rect(ref, q.layer, rect);
  int64_t changed = 0;
  for (size_t i = 0; i < before.size(); ++i) changed += before[i] != ref_samples[i];
  const std::vector<TileChange> ref_changes = ref.commit(seq);
  const std::vector<FastIsa> all = isas();
  for (size_t k = 0; k < all.size(); ++k) {
    const FastIsa isa = all[k];
    SCOPED_TRACE(what + " isa=" + isa_name(isa));
    World& w = fast[k];
    const auto fr = apply_stamp_with(w, q, isa, reg, limits);
    EXPECT_EQ(rr.ok(), fr.ok());
    if (!rr.ok() || !fr.ok()) continue;
    EXPECT_EQ(rr.value(), fr.value()) << "returned changed rect";
    const std::vector<int32_t> got = read_rect(w, q.layer, rect);
    size_t first_diff = got.size();
    for (size_t i = 0; i < got.size() && first_diff == got.size(); ++i) {
      if (got[i] != ref_samples[i]) first_diff = i;
    }
    EXPECT_EQ(first_diff, got.size())
        << "first differing sample (row-major in the stamp rect) " << first_diff << ": fast "
        << (first_diff < got.size() ? got[first_diff] : 0) << " reference "
        << (first_diff < got.size() ? ref_samples[first_diff] : 0);
    EXPECT_EQ(w.detail_tile_count(), ref.detail_tile_count())
        << "detail tiles created only where a sample changed";
    const std::vector<TileChange> changes = w.commit(seq);
    EXPECT_EQ(changes.size(), ref_changes.size()) << "dirty tiles after commit";
    for (size_t i = 0; i < changes.size() && i < ref_changes.size(); ++i) {
      EXPECT_EQ(changes[i].coord, ref_changes[i].coord);
      EXPECT_EQ(changes[i].rect, ref_changes[i].rect);
    }
    EXPECT_EQ(w.world_hash(), ref.world_hash());
  }
  return changed;
}

// The same from copies of `base`, which stays as it is.
int64_t expect_same_as_reference(const World& base, const QuantizedStamp& q, const TextureRegistry* reg,
                                 const std::string& what, const StampLimits& limits = {}) {
  World ref = base;
  std::vector<World> fast(isas().size(), base);
  return expect_step_matches_reference(ref, fast, q, reg, what, limits, 2);
}

// A random valid stamp of any per-sample kind, aimed at tile borders, corners and the world's
// edges (protocol/stamps/stamp_mix.h). Radii up to `max_radius` samples.
StampParams random_params(Rng& rng, const WorldParams& p, double max_radius, uint64_t texture_id) {
  RandomStampOptions o;
  o.kinds = {StampKind::kTexture, StampKind::kGaussian, StampKind::kCrater, StampKind::kFootprint,
             StampKind::kFlatten};
  o.texture_id = texture_id;
  return random_edge_case_stamp_params(rng, p, max_radius, o);
}

uint64_t add_random_texture(Rng& rng, TextureRegistry& reg) {
  const int32_t w = int32_t(rng.range(1, 40)), h = int32_t(rng.range(1, 40));
  std::vector<uint16_t> px(size_t(w * h));
  for (auto& v : px) v = uint16_t(rng.chance(10) ? 65535 : rng.range(0, 65535));
  auto id = reg.add(w, h, px);
  EXPECT_TRUE(id.ok());
  return id.ok() ? id.value() : 0;
}

// A run of `count` random stamps. Each is applied to the reference's world and to one world per
// ISA, all equal before it (a divergence fails that stamp); every 50 stamps they start again from
// a fresh random world. Stamping in sequence, rather than each stamp from a copy of one world,
// also meets terrain that earlier stamps carved and saturated, and spares the four world copies
// per stamp that were most of this test's time under the sanitizers.
int run_random_stamps(uint32_t seed, int count, double max_radius, const StampLimits& limits = {}) {
  Rng rng(seed);
  const WorldParams p = corner_world_params();
  TextureRegistry reg;
  int applied = 0;
  World ref = random_world(rng, p);
  std::vector<World> fast(isas().size(), ref);
  uint64_t seq = 1;
  for (int i = 0; i < count; ++i) {
    if (i % 50 == 0) {
      ref = random_world(rng, p);
      std::fill(fast.begin(), fast.end(), ref);
      seq = 1;
    }
    const uint64_t tex = add_random_texture(rng, reg);
    const StampParams s = random_params(rng, p, max_radius, tex);
    auto q = validate_stamp(s, p, limits, &reg);
    if (!q.ok()) continue;  // e.g. a crater flag with a min blend: validation's business
    expect_step_matches_reference(ref, fast, q.value(), &reg,
                                  "seed " + std::to_string(seed) + " stamp " + std::to_string(i) + " kind " +
                                      to_string(q.value().kind) + " layer " +
                                      std::to_string(int(q.value().layer)) + " radius_q8 " +
                                      std::to_string(q.value().radius),
                                  limits, ++seq);
    ++applied;
    if (::testing::Test::HasFailure()) break;  // one readable failure, not thousands
  }
  return applied;
}

// ----------------------------------------------------------------------------------------

// The integer square root is where a float shortcut would go wrong: float(d2) rounds above
// 2^24, so trunc(sqrtf) is one off just below and at perfect squares. The correction must
// give isqrt32 exactly on both sides of every square the kernel can meet (d2 < 2^29).
TEST(FastStamp, FloatSquareRootIsCorrectedToTheExactIntegerRootAroundEveryPerfectSquare) {
  std::vector<uint32_t> in;
  for (uint32_t k = 0; k * k < (1u << 29); ++k) {
    const uint32_t sq = k * k;
    if (sq > 0) in.push_back(sq - 1);
    in.push_back(sq);
    in.push_back(sq + 1);
    in.push_back(sq + k);  // the middle, where the root is k + ~0.5
  }
  in.push_back((1u << 29) - 1);
  for (const FastIsa isa : isas()) {
    std::vector<uint32_t> out(in.size());
    fast_isqrt_for_test(in, out, isa);
    size_t bad = 0;
    for (size_t i = 0; i < in.size(); ++i) bad += out[i] != isqrt32(in[i]);
    EXPECT_EQ(bad, 0u) << isa_name(isa) << " over " << in.size() << " values";
  }
}

// The kernel divides by the reduced radius with a multiply and a shift: for every divisor it
// can meet (1 <= Rr < 2^14) the quotient must be the division's at every dist it divides
// (dist <= Rr, numerator dist << 16), and at the numerators where a rounding error would show
// first: just below each multiple of the divisor, up to the 2^30 bound.
TEST(FastStamp, TheReciprocalOfTheReducedRadiusDividesExactlyForEveryRadius) {
  uint64_t bad = 0, checked = 0;
  for (uint32_t d = 1; d < (1u << 14); ++d) {
    const ExactDivisor div(d);
    EXPECT_LT(div.m, uint64_t(1) << 32) << d;
    for (uint32_t dist = 0; dist <= d; ++dist) {
      const uint32_t n = dist << 16;
      bad += div.divide(n) != n / d;
      ++checked;
    }
    for (uint32_t q = (1u << 30) / d; q > 0 && q + 64 > (1u << 30) / d; --q) {
      const uint32_t n = q * d - 1;
      bad += div.divide(n) != n / d;
      bad += div.divide(n + 1) != (n + 1) / d;
      checked += 2;
    }
  }
  EXPECT_EQ(bad, 0u) << "over " << checked << " quotients";
}

TEST(FastStamp, ThousandsOfSeededRandomStampsMatchTheReferenceTexelForTexel) {
  int applied = 0;
  for (uint32_t seed = 1; seed <= 4; ++seed) applied += run_random_stamps(seed, 500, 48.0);
  EXPECT_GT(applied, 1800);
}

// Large stamps reach the per-dist tables under the cost heuristic (kBest) and the world edge
// clips them; the 4096-sample default cap gives the reduction shift 7.
TEST(FastStamp, LargeRandomStampsClippedByTheWorldEdgeMatchTheReference) {
  const int applied = run_random_stamps(77, 120, 4096.0);
  EXPECT_GT(applied, 100);
}

// Radii above 8192 samples (hard cap 65536) shift by more than 8, so the reduced offset of
// consecutive samples no longer steps evenly: every sample's |d| >> s must be taken afresh.
TEST(FastStamp, RadiiBeyondEightThousandSamplesWithUnevenReducedStepsMatchTheReference) {
  StampLimits limits;
  limits.max_radius_samples = 65536;
  const WorldParams p = corner_world_params();
  Rng rng(5);
  const World base = random_world(rng, p);
  for (const double r : {8200.0, 20000.0, 65536.0}) {
    for (const StampKind kind : {StampKind::kGaussian, StampKind::kCrater, StampKind::kFlatten}) {
      StampParams s =
          stamps_test::make_params(kind, 10.3, -200.7, r, kind == StampKind::kFlatten ? 0.8 : 300.0);
      s.shape = 0.4;
      if (kind == StampKind::kFlatten) s.target = 100.0;  // the others take no target
      auto q = validate_stamp(s, p, limits);
      ASSERT_TRUE(q.ok()) << q.error().describe();
      EXPECT_GT(expect_same_as_reference(base, q.value(), nullptr, "radius " + std::to_string(r), limits), 0);
    }
  }
}

// Every sub-sample center offset with integer radii puts disc edges exactly on samples
// (d2 == Rr² is outside): the row span's ends must match the per-sample test, at the
// four-tile corner where each row also splits across two tiles.
TEST(FastStamp, RowSpanEndsMatchTheDiscTestForEverySubSampleCenterOffsetAtTheFourTileCorner) {
  const WorldParams p = corner_world_params();
  const World base(p, 30000);
  for (int32_t fx = 0; fx < 256; fx += 5) {
    for (const double r : {1.0, 3.0, 7.5, 64.0, 100.0}) {
      const double cx = double(fx) / 256.0, cy = -double((fx * 7) % 256) / 256.0;
      StampParams s = stamps_test::make_params(StampKind::kGaussian, cx, cy, r, 3.0);
      const QuantizedStamp q = stamps_test::must_validate(s, p);
      expect_same_as_reference(base, q, nullptr, "fx " + std::to_string(fx) + " r " + std::to_string(r));
    }
  }
}

// Radii below one sample: the reduced radius is tiny (down to 1), the table has a single
// entry and most stamps touch zero or one sample.
TEST(FastStamp, SubSampleRadiiMatchTheReference) {
  const WorldParams p = corner_world_params();
  const World base(p, 1000);
  int changed_some = 0;
  for (int32_t rq = 1; rq <= 300; rq += 7) {
    for (const Layer layer : {Layer::kCoarse, Layer::kDetail}) {
      QuantizedStamp q;
      q.kind = StampKind::kGaussian;
      q.layer = layer;
      q.center_x = 3;  // just off sample 0
      q.center_y = -2;
      q.radius = uint32_t(rq);
      q.intensity = layer == Layer::kCoarse ? 50 * 256 : 100 * 256;
      changed_some += expect_same_as_reference(base, q, nullptr, "radius_q8 " + std::to_string(rq)) > 0;
    }
  }
  EXPECT_GT(changed_some, 0);
}

// Maximal intensities on terrain at the layer's floor and ceiling: every blend saturates and
// the vector kernel's narrowing store must not wrap.
TEST(FastStamp, SaturatingIntensitiesAtTheLayerFloorAndCeilingMatchTheReference) {
  const WorldParams p = corner_world_params();
  for (const uint16_t fill : {uint16_t(0), uint16_t(65535), uint16_t(3)}) {
    World base(p, fill);
    for (const Layer layer : {Layer::kCoarse, Layer::kDetail}) {
      for (int32_t blend = 0; blend < kBlendModeCount; ++blend) {
        for (const int32_t sign : {1, -1}) {
          QuantizedStamp q;
          q.kind = StampKind::kCrater;
          q.layer = layer;
          q.blend = BlendMode(blend);
          q.center_x = -77;
          q.center_y = 130;
          q.radius = 150 * 256;
          q.shape = 40000;
          q.intensity = sign * (layer == Layer::kCoarse ? 65535 : 255) * 256;
          q.target = q.blend == BlendMode::kMin || q.blend == BlendMode::kMax
                         ? (layer == Layer::kCoarse ? 65535 : -128)
                         : 0;
          expect_same_as_reference(base, q, nullptr,
                                   "fill " + std::to_string(fill) + " blend " + std::to_string(blend) +
                                       " sign " + std::to_string(sign));
        }
      }
    }
  }
}

// A footprint whose foot lies entirely outside the world has no contact and changes nothing;
// one straddling the corner takes its contact from samples of four tiles.
TEST(FastStamp, FootprintContactAcrossFourTilesAndOffTheWorldMatchesTheReference) {
  Rng rng(9);
  const WorldParams p = corner_world_params();
  const World base = random_world(rng, p);
  for (const double cx : {0.4, -255.9, 255.9}) {
    StampParams s = stamps_test::make_params(StampKind::kFootprint, cx, -cx, 40.0, 2.0);
    s.shape = 0.7;
    expect_same_as_reference(base, stamps_test::must_validate(s, p), nullptr, "cx " + std::to_string(cx));
    s.layer = Layer::kDetail;
    s.intensity = 0.3;
    expect_same_as_reference(base, stamps_test::must_validate(s, p), nullptr,
                             "detail cx " + std::to_string(cx));
  }
}

// Texture stamps large enough for the per-axis tables, at every eighth of a turn and odd
// image sizes (1x1 clamps both neighbours to one pixel).
TEST(FastStamp, TextureStampsAtEveryEighthTurnAndOddImageSizesMatchTheReference) {
  Rng rng(11);
  const WorldParams p = corner_world_params();
  const World base = random_world(rng, p);
  TextureRegistry reg;
  for (const auto& [w, h] : std::vector<std::pair<int32_t, int32_t>>{{1, 1}, {3, 7}, {64, 64}, {257, 5}}) {
    std::vector<uint16_t> px(size_t(w * h));
    for (auto& v : px) v = uint16_t(rng.range(0, 65535));
    const uint64_t id = reg.add(w, h, px).value();
    for (int32_t eighth = 0; eighth < 8; ++eighth) {
      StampParams s = stamps_test::make_params(StampKind::kTexture, 0.3, -0.6, 90.0, 20.0);
      s.texture_id = id;
      s.rotation = double(eighth) * 0.7853981633974483;
      expect_same_as_reference(
          base, stamps_test::must_validate(s, p, &reg), &reg,
          std::to_string(w) + "x" + std::to_string(h) + " eighth " + std::to_string(eighth));
    }
  }
}

// Detail stamps that change nothing (zero intensity, or min against a floor) must not create
// detail tiles; ones that do must create exactly the reference's.
TEST(FastStamp, DetailTilesAreCreatedOnlyWhereASampleChanges) {
  const WorldParams p = corner_world_params();
  const World base(p, 100);
  for (const double intensity : {0.0, 0.002, 0.5}) {
    StampParams s = stamps_test::make_params(StampKind::kGaussian, 0.1, 0.1, 300.0, intensity);
    s.layer = Layer::kDetail;
    expect_same_as_reference(base, stamps_test::must_validate(s, p), nullptr,
                             "intensity " + std::to_string(intensity));
  }
}

}  // namespace
}  // namespace loam
