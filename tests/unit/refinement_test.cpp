// The refinement (protocol/base/refinement.h) and the refined default world
// (dem/refined_default.h): tiles agree with larger evaluations across seams and corners,
// mips are decimations of mip 0, the source level is the source, extremes saturate
// without overflow, and the result is pinned by a golden hash built by GCC and clang.
#include "protocol/base/refinement.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "dem/refined_default.h"
#include "protocol/tile_hash.h"
#include "tests/determinism/refinement_sequence.h"

namespace loam {
namespace {

std::vector<int32_t> hashed_source(int32_t w, int32_t h, uint32_t seed, int32_t lo, int32_t hi) {
  std::vector<int32_t> s(size_t(w) * size_t(h));
  for (auto& v : s) {
    seed = seed * 1664525u + 1013904223u;
    v = lo + int32_t((uint64_t(seed >> 8) * uint64_t(hi - lo + 1)) >> 24);
  }
  return s;
}

RefinementParams rough_params(int32_t levels) {
  RefinementParams p;
  p.levels = levels;
  p.seed = 77;
  for (int32_t l = 0; l < levels; ++l) p.amplitude[size_t(l)] = 400 << l;
  p.roughness_base = 200;
  p.roughness_gain = 2;
  p.roughness_max = 1500;
  return p;
}

std::vector<uint16_t> generate(const RefinedBase& b, int32_t mip, const RectI& r) {
  std::vector<uint16_t> out(size_t(r.area()));
  b.generate(mip, r, out);
  return out;
}

TEST(Refinement, TilesEqualTheSameRectOfOneLargerEvaluationAcrossSeamsAndCorners) {
  auto base = RefinedBase::create(7, 5, hashed_source(7, 5, 1, 20000, 40000), rough_params(6));
  ASSERT_TRUE(base.ok());
  for (int32_t mip : {0, 1, 3, 5}) {
    // A 3x3 block of tiles around a four-tile corner, including tiles at negative positions.
    const RectI big{-kTileSize, -kTileSize, 2 * kTileSize, 2 * kTileSize};
    const auto all = generate(*base, mip, big);
    for (int32_t ty = -1; ty < 2; ++ty) {
      for (int32_t tx = -1; tx < 2; ++tx) {
        std::vector<uint16_t> tile(static_cast<size_t>(kTileSamples));
        base->generate_tile(mip, tx, ty, tile);
        for (int32_t y = 0; y < kTileSize; ++y) {
          for (int32_t x = 0; x < kTileSize; ++x) {
            const size_t k =
                size_t((int64_t(ty + 1) * kTileSize + y) * big.width() + (tx + 1) * kTileSize + x);
            ASSERT_EQ(tile[size_t(y * kTileSize + x)], all[k])
                << "mip " << mip << " tile " << tx << "," << ty;
          }
        }
      }
    }
    // Odd rects that start and end mid-cell agree too.
    const RectI odd{37, -13, 301, 99};
    const auto part = generate(*base, mip, odd);
    for (int64_t y = odd.y0; y < odd.y1; ++y)
      for (int64_t x = odd.x0; x < odd.x1; ++x)
        ASSERT_EQ(part[size_t((y - odd.y0) * odd.width() + (x - odd.x0))],
                  all[size_t((y - big.y0) * big.width() + (x - big.x0))]);
  }
}

TEST(Refinement, EveryMipIsTheDecimationOfTheMipBelow) {
  auto base = RefinedBase::create(9, 6, hashed_source(9, 6, 2, 0, 65535), rough_params(5));
  ASSERT_TRUE(base.ok());
  for (int32_t mip = 0; mip + 1 < 9; ++mip) {
    const RectI fine{-20, 10, 2 * kTileSize + 20, 2 * kTileSize + 10};
    const RectI coarse{-10, 5, kTileSize + 10, kTileSize + 5};
    const auto f = generate(*base, mip, fine);
    const auto c = generate(*base, mip + 1, coarse);
    for (int64_t y = coarse.y0; y < coarse.y1; ++y)
      for (int64_t x = coarse.x0; x < coarse.x1; ++x)
        ASSERT_EQ(c[size_t((y - coarse.y0) * coarse.width() + (x - coarse.x0))],
                  f[size_t((2 * y - fine.y0) * fine.width() + (2 * x - fine.x0))])
            << "mip " << mip + 1 << " sample " << x << "," << y;
  }
}

TEST(Refinement, TheSourceLevelIsTheSourceAndCoarserMipsDecimateIt) {
  const int32_t w = 300, h = 260;
  const auto src = hashed_source(w, h, 3, 0, 65535);
  auto base = RefinedBase::create(w, h, src, rough_params(4));
  ASSERT_TRUE(base.ok());
  std::vector<uint16_t> tile(static_cast<size_t>(kTileSamples));
  base->generate_tile(4, 1, 0, tile);
  for (int32_t y = 0; y < kTileSize; ++y)
    for (int32_t x = 0; x < kTileSize; ++x) {
      const int32_t sx = std::min(kTileSize + x, w - 1);
      ASSERT_EQ(tile[size_t(y * kTileSize + x)], src[size_t(y * w + sx)]);
    }
  base->generate_tile(6, 0, 0, tile);
  for (int32_t y = 0; y < kTileSize; ++y)
    for (int32_t x = 0; x < kTileSize; ++x)
      ASSERT_EQ(tile[size_t(y * kTileSize + x)],
                src[size_t(std::min(4 * y, h - 1) * w + std::min(4 * x, w - 1))]);
}

TEST(Refinement, FlatSourceWithoutAmplitudeStaysFlatAndInterpolationIsExactOnRamps) {
  RefinementParams p;
  p.levels = 5;
  auto flat = RefinedBase::create(4, 4, std::vector<int32_t>(16, 1234), p);
  ASSERT_TRUE(flat.ok());
  const auto f = generate(*flat, 0, {0, 0, kTileSize, kTileSize});
  EXPECT_TRUE(std::all_of(f.begin(), f.end(), [](uint16_t v) { return v == 1234; }));
  // The 4-point scheme reproduces cubics, so a linear ramp refines to the exact ramp.
  std::vector<int32_t> ramp(8 * 8);
  for (int32_t y = 0; y < 8; ++y)
    for (int32_t x = 0; x < 8; ++x) ramp[size_t(y * 8 + x)] = 1000 + 64 * x;
  auto r = RefinedBase::create(8, 8, ramp, p);
  ASSERT_TRUE(r.ok());
  const auto g = generate(*r, 0, {64, 64, 160, 96});
  for (int64_t y = 0; y < 32; ++y)
    for (int64_t x = 0; x < 96; ++x) ASSERT_EQ(g[size_t(y * 96 + x)], 1000 + 2 * (64 + x));
}

TEST(Refinement, ExtremeSourcesAndAmplitudesSaturateWithoutOverflow) {
  // Values far outside 0..65535, alternating, with the largest amplitudes and roughness:
  // UBSan in CI checks the arithmetic; the output must cover both limits.
  std::vector<int32_t> src(6 * 6);
  for (size_t i = 0; i < src.size(); ++i) src[i] = (i % 2) ? 1 << 30 : -(1 << 30);
  RefinementParams p;
  p.levels = 6;
  p.amplitude.fill(1 << 20);
  p.roughness_base = 1 << 16;
  p.roughness_gain = 1 << 16;
  p.roughness_max = 1 << 16;
  auto base = RefinedBase::create(6, 6, src, p);
  ASSERT_TRUE(base.ok());
  bool saw_min = false, saw_max = false;
  for (int32_t mip = 0; mip < 8; ++mip) {
    const auto t = generate(*base, mip, {-300, -300, 300, 300});
    saw_min = saw_min || std::count(t.begin(), t.end(), 0) > 0;
    saw_max = saw_max || std::count(t.begin(), t.end(), 65535) > 0;
  }
  EXPECT_TRUE(saw_min);
  EXPECT_TRUE(saw_max);
  // At the top of the range with no displacement, the world stays at the top.
  RefinementParams q;
  q.levels = 3;
  auto top = RefinedBase::create(3, 3, std::vector<int32_t>(9, 65535), q);
  ASSERT_TRUE(top.ok());
  const auto t = generate(*top, 0, {0, 0, 24, 24});
  EXPECT_TRUE(std::all_of(t.begin(), t.end(), [](uint16_t v) { return v == 65535; }));
}

TEST(Refinement, TheSeedChangesTheDetailButNotTheSourceSamples) {
  const auto src = hashed_source(5, 5, 4, 10000, 50000);
  auto p = rough_params(4);
  auto a = RefinedBase::create(5, 5, src, p);
  p.seed = 78;
  auto b = RefinedBase::create(5, 5, src, p);
  ASSERT_TRUE(a.ok() && b.ok());
  const RectI r{0, 0, 80, 80};
  const auto ga = generate(*a, 0, r), gb = generate(*b, 0, r);
  EXPECT_NE(ga, gb);
  for (int64_t y = 0; y < 80; y += 16)
    for (int64_t x = 0; x < 80; x += 16) EXPECT_EQ(ga[size_t(y * 80 + x)], gb[size_t(y * 80 + x)]);
}

TEST(Refinement, RejectsParametersAndSourcesOutOfRange) {
  RefinementParams p;
  p.levels = 0;
  EXPECT_EQ(p.validate().error().field, "refinement.levels");
  p.levels = kMaxRefineLevels + 1;
  EXPECT_FALSE(p.validate().ok());
  p.levels = 4;
  p.amplitude[2] = -1;
  EXPECT_EQ(p.validate().error().field, "refinement.amplitude[2]");
  p.amplitude[2] = 0;
  p.roughness_max = -5;
  EXPECT_EQ(p.validate().error().field, "refinement.roughness_max");
  p.roughness_max = 100;
  EXPECT_FALSE(RefinedBase::create(3, 3, std::vector<int32_t>(8), p).ok());
  EXPECT_FALSE(RefinedBase::create(0, 3, {}, p).ok());
  EXPECT_TRUE(RefinedBase::create(3, 3, std::vector<int32_t>(9), p).ok());
}

TEST(Refinement, GoldenHashIsTheOneClangReproduces) {
  EXPECT_EQ(determinism::golden_refinement_hash(), determinism::kGoldenRefinementHash)
      << std::hex << determinism::golden_refinement_hash();
}

TEST(RefinedDefault, IsAWorldOfAtLeast65536SquaredSamplesAtOneMetre) {
  auto w = load_refined_default();
  ASSERT_TRUE(w.ok()) << w.error().describe();
  EXPECT_EQ(w->params.meters_per_sample, 1.0);
  EXPECT_GE(int64_t(w->params.tiles_x) * kTileSize, 65536);
  EXPECT_GE(int64_t(w->params.tiles_y) * kTileSize, 65536);
  EXPECT_EQ(w->base.width(), int64_t(w->params.tiles_x) * kTileSize);
  EXPECT_EQ(w->base.height(), int64_t(w->params.tiles_y) * kTileSize);
  // Sea level sits at 0 m: Tibet stands hundreds of metres above it (1/8 of its height),
  // the sea floor a hundred or more below (1/32 of its depth).
  std::vector<uint16_t> tile(static_cast<size_t>(kTileSamples));
  w->base.generate_tile(w->params.mip_count() - 1, 0, 0, tile);
  const auto [lo, hi] = std::minmax_element(tile.begin(), tile.end());
  EXPECT_LT(w->params.height_meters(*lo), -100.0);
  EXPECT_GT(w->params.height_meters(*hi), 500.0);
  EXPECT_GT(*lo, 0);
  EXPECT_LT(*hi, 65535);
}

TEST(RefinedDefault, TilesArePinnedSoAChangeOfMethodOrParametersIsSeen) {
  // Regenerate with the printed value only when the default world is meant to change
  // (its world hash changes with it, and so do the replay logs that start from it).
  auto w = load_refined_default();
  ASSERT_TRUE(w.ok());
  WorldHasher hasher;
  std::vector<uint16_t> tile(static_cast<size_t>(kTileSamples));
  for (int32_t mip : {0, 2, 5, 7, 9}) {
    const RectI range = w->params.tile_range(mip);
    const int32_t tx = int32_t(range.x0 + range.width() * 45 / 100),
                  ty = int32_t(range.y0 + range.height() * 3 / 10);
    w->base.generate_tile(mip, tx, ty, tile);
    hasher.add(uint8_t(mip), tx, ty, hash_coarse_tile(tile));
  }
  EXPECT_EQ(hasher.finish(), 0x8e6f018632e3e48eull) << std::hex << hasher.finish();
}

}  // namespace
}  // namespace loam
