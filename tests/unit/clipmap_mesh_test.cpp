// The clipmap mesh the renderer draws, checked on its CPU replica: no cracks, overlaps or
// T-junctions across levels, for several sizes, level counts and camera positions (negative
// and far from the origin), and the placement invariants the geomorph band relies on.
#include "client/lod/clipmap_mesh.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace loam::lod {
namespace {

struct Camera {
  double x, y;
};

const Camera kCameras[] = {{0.0, 0.0},
                           {0.5, 0.5},
                           {1.0, 3.0},
                           {-1.0, -1.0},
                           {-77.25, 1031.5},
                           {12345.7, -9876.1},
                           {4.1e9 + 0.25, -3.3e9},
                           {-5.0e9, 5.0e9 + 1.0}};

void expect_watertight(int32_t n, int32_t levels, Camera cam) {
  auto mesh = ClipmapMesh::build(n);
  ASSERT_TRUE(mesh.ok());
  const auto placed = place_levels(n, levels, cam.x, cam.y);
  const auto tris = replicate(*mesh, placed);
  const WatertightReport r = check_watertight(tris, placed.back().sample_rect(n));
  EXPECT_TRUE(r.ok()) << "n " << n << " L " << levels << " camera " << cam.x << "," << cam.y << ": "
                      << r.describe();
  EXPECT_EQ(r.boundary_edges, 4 * (n - 1));
}

TEST(ClipmapMesh, AllLevelsTogetherAreWatertightWithNoTJunctions) {
  for (int32_t n : {7, 15, 31, 63}) {
    for (int32_t levels : {1, 2, 3, n < 63 ? 5 : 4}) {
      for (const Camera& c : kCameras) expect_watertight(n, levels, c);
    }
  }
}

TEST(ClipmapMesh, LargeLevelsAreWatertightAtRandomCameras) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-1.0e6, 1.0e6);
  for (int i = 0; i < 3; ++i) expect_watertight(127, 3, {u(rng), u(rng)});
  expect_watertight(255, 2, {u(rng), u(rng)});
}

// Without the zero-area boundary triangles every fine boundary vertex sits inside a coarse
// edge: the checker must see that, or its "watertight" means nothing.
TEST(ClipmapMesh, CheckerReportsTJunctionsWhenDegenerateTrianglesAreLeftOut) {
  auto mesh = ClipmapMesh::build(15);
  ASSERT_TRUE(mesh.ok());
  const auto placed = place_levels(15, 3, 3.5, -2.0);
  const WatertightReport r = check_watertight(replicate(*mesh, placed, false), placed.back().sample_rect(15));
  EXPECT_FALSE(r.ok());
  EXPECT_EQ(r.t_junctions, 2 * 4 * 7);  // 7 odd boundary vertices per side, 2 inner levels
  EXPECT_GT(r.open_edges, 0);
}

TEST(ClipmapMesh, RejectsSizesThatAreNotTwoToTheKMinusOne) {
  EXPECT_FALSE(ClipmapMesh::build(64).ok());
  EXPECT_FALSE(ClipmapMesh::build(3).ok());
  EXPECT_FALSE(ClipmapMesh::build(2047).ok());
  EXPECT_TRUE(ClipmapMesh::build(7).ok());
}

TEST(ClipmapMesh, PiecesCoverEachLevelOnceAndTrianglesPerLevelIsTheGrid) {
  auto mesh = ClipmapMesh::build(31);
  ASSERT_TRUE(mesh.ok());
  EXPECT_EQ(mesh->ring().size(), 16u);
  // Ring + trim = the n x n grid minus the finer level's (n - 1) / 2 quads per side.
  EXPECT_EQ(mesh->triangles_per_level(), 2 * (30 * 30 - 15 * 15));
  EXPECT_EQ(mesh->fill().index_count / 3, uint32_t(2 * 16 * 16));
}

// Each level's centre stays within one of its samples of the camera, and the finer level sits
// 0 or 1 sample past the hole's low corner: what the geomorph band's width assumes.
TEST(ClipmapMesh, EveryLevelIsCentredOnTheCameraWithinOneSampleAndNested) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0e7, 1.0e7);
  const int32_t n = 63, m = 16;
  for (int i = 0; i < 2000; ++i) {
    const double cx = u(rng), cy = u(rng);
    const auto placed = place_levels(n, 8, cx, cy);
    for (const LevelPlacement& p : placed) {
      const double s = double(p.spacing());
      EXPECT_EQ(floor_mod(p.origin_x, 2 * p.spacing()), 0);
      EXPECT_LE(std::abs((double(p.origin_x) + (n - 1) / 2.0 * s - cx) / s), 1.0);
      EXPECT_LE(std::abs((double(p.origin_y) + (n - 1) / 2.0 * s - cy) / s), 1.0);
      if (p.level == 0) continue;
      const LevelPlacement& f = placed[size_t(p.level - 1)];
      const int64_t dx = (f.origin_x - p.origin_x) / p.spacing() - (m - 1);
      const int64_t dy = (f.origin_y - p.origin_y) / p.spacing() - (m - 1);
      EXPECT_TRUE(dx == 0 || dx == 1) << dx;
      EXPECT_TRUE(dy == 0 || dy == 1) << dy;
    }
  }
}

// The blend must be 1 on a level's outer boundary (it meets the coarser level there) and 0
// where the finer level meets it (the hole's edge), wherever the camera is.
TEST(ClipmapMesh, MorphBandEndsAtTheOuterEdgeAndStartsOutsideTheHole) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(-1.0e5, 1.0e5);
  for (int32_t n : {15, 31, 127}) {
    const int32_t m = (n + 1) / 4;
    ASSERT_GT(morph_band(n), 0);
    for (int i = 0; i < 300; ++i) {
      const double cx = u(rng), cy = u(rng);
      for (const LevelPlacement& p : place_levels(n, 5, cx, cy)) {
        const double s = double(p.spacing());
        const double vx = (cx - double(p.origin_x)) / s, vy = (cy - double(p.origin_y)) / s;
        for (int32_t k = 0; k < n; ++k) {
          // Outer boundary, with the shader's forcing switched off by sampling just inside.
          EXPECT_GE(morph_alpha(n, 0.001, k, vx, vy), 0.999 - 1e-9);
          EXPECT_GE(morph_alpha(n, n - 1.001, k, vx, vy), 0.999 - 1e-9);
        }
        for (int32_t k = m - 1; k <= 3 * m - 1; ++k) {
          EXPECT_EQ(morph_alpha(n, m - 1, k, vx, vy), 0.0);
          EXPECT_EQ(morph_alpha(n, 3 * m - 1, k, vx, vy), 0.0);
          EXPECT_EQ(morph_alpha(n, k, m - 1, vx, vy), 0.0);
          EXPECT_EQ(morph_alpha(n, k, 3 * m - 1, vx, vy), 0.0);
        }
      }
    }
  }
}

// Moving the camera by a multiple of 2^L samples moves every level by the same amount: the
// mesh relative to the camera is the same, which is what makes far-origin renders identical.
TEST(ClipmapMesh, ShiftByMultipleOfTwoToTheLevelsGivesTheSameRelativePlacement) {
  const int32_t n = 63, levels = 7;
  const int64_t shift = (int64_t(1) << levels) * 256 * 153;  // ~10,000 km at 2 m per sample
  for (const Camera& c : kCameras) {
    const auto a = place_levels(n, levels, c.x, c.y);
    const auto b = place_levels(n, levels, c.x + double(shift), c.y - double(shift));
    for (size_t l = 0; l < a.size(); ++l) {
      EXPECT_EQ(b[l].origin_x - a[l].origin_x, shift);
      EXPECT_EQ(b[l].origin_y - a[l].origin_y, -shift);
      EXPECT_EQ(b[l].trim_variant, a[l].trim_variant);
    }
  }
}

TEST(ClipmapMesh, LevelCountFollowsViewDistance) {
  EXPECT_EQ(levels_for_view_distance(127, 2.0, 100.0), 1);
  const int32_t l = levels_for_view_distance(127, 2.0, 3000.0);
  EXPECT_GE((127 - 1) / 2.0 * double(int64_t(1) << (l - 1)) * 2.0, 3000.0);
  EXPECT_LT((127 - 1) / 2.0 * double(int64_t(1) << (l - 2)) * 2.0, 3000.0);
}

// A toroidal region that moves loads exactly the samples that came into view, each once.
TEST(ClipmapMesh, ToroidalStripsLoadExactlyTheSamplesThatCameIntoView) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int64_t> step(-9, 9), jump(-40, 40);
  const int64_t size = 23;
  std::array<int64_t, 2> at{-5, 17};
  EXPECT_EQ(toroidal_strips(std::nullopt, at, size), (std::vector<RectI>{{-5, 17, 18, 40}}));
  for (int i = 0; i < 300; ++i) {
    const std::array<int64_t, 2> next{at[0] + (i % 10 == 0 ? jump(rng) : step(rng)),
                                      at[1] + (i % 10 == 0 ? jump(rng) : step(rng))};
    const RectI old{at[0], at[1], at[0] + size, at[1] + size},
        now{next[0], next[1], next[0] + size, next[1] + size};
    std::vector<int> loaded(size_t(size * size), 0);
    for (const RectI& r : toroidal_strips(at, next, size)) {
      ASSERT_TRUE(now.contains(r)) << "strip outside the new region";
      for (int64_t y = r.y0; y < r.y1; ++y) {
        for (int64_t x = r.x0; x < r.x1; ++x) ++loaded[size_t((y - now.y0) * size + (x - now.x0))];
      }
    }
    const bool jumped = std::abs(next[0] - at[0]) >= size || std::abs(next[1] - at[1]) >= size;
    for (int64_t y = now.y0; y < now.y1; ++y) {
      for (int64_t x = now.x0; x < now.x1; ++x) {
        const int want = jumped || !old.contains(x, y) ? 1 : 0;
        ASSERT_EQ(loaded[size_t((y - now.y0) * size + (x - now.x0))], want) << "sample " << x << "," << y;
      }
    }
    at = next;
  }
}

}  // namespace
}  // namespace loam::lod
