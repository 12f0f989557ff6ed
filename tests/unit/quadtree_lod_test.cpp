// Ulrich's adaptive quadtree (client/lod/quadtree.h) on its CPU replica: square errors that
// bound the leaf surface, restricted and watertight meshes from any view, the screen-error
// budget met at every sample, geomorphing that bounds the surface change per camera step, a
// stamp that recomputes exactly the squares holding its samples, and a mesh rebuilt only in
// the blocks whose subdivision changed.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "client/lod/quadtree.h"
#include "lod_test_terrain.h"

namespace loam::lod {
namespace {

using namespace test;

QuadtreeGrid quadtree_grid_for(const Terrain& t, int32_t block) {
  auto g = QuadtreeGrid::make(t.width, t.height, block);
  EXPECT_TRUE(g.ok()) << g.error().describe();
  return *g;
}

TEST(QuadtreeLod, BlockSizesArePowersOfTwoAndBlocksCoverTheWorld) {
  EXPECT_FALSE(QuadtreeGrid::make(100, 100, 48).ok());
  EXPECT_FALSE(QuadtreeGrid::make(100, 100, 2).ok());
  EXPECT_FALSE(QuadtreeGrid::make(100, 100, 512).ok());
  auto g = QuadtreeGrid::make(203, 150, 64);
  ASSERT_TRUE(g.ok());
  EXPECT_EQ(g->levels, 6);
  EXPECT_EQ(g->blocks_x, 4);
  EXPECT_EQ(g->blocks_y, 3);
  EXPECT_GE(g->covered().x1, 203);
}

TEST(QuadtreeLod, ALeafsErrorBoundsItsSurfaceWhateverItsSidesCarry) {
  const Terrain t = rough(129, 129, 3);
  const QuadtreeGrid g = quadtree_grid_for(t, 32);
  const QuadtreeErrors e = QuadtreeErrors::compute(g, t.grid());
  // Subdivide everything down to `level`, so every leaf is of that level, with every side's
  // midpoint present (neighbours subdivided) or none (nothing below).
  for (int32_t level = 1; level <= g.levels; ++level) {
    QuadtreeState s(g);
    for (int32_t l = level + 1; l <= g.levels; ++l)
      for (int32_t j = 0; j < g.squares_y(l); ++j)
        for (int32_t i = 0; i < g.squares_x(l); ++i) s.set(l, i, j, true, 1.0f);
    const auto surface = displayed_surface(g, t.grid(), s);
    const int64_t cw = g.covered().width();
    for (int32_t j = 0; j < g.squares_y(level); ++j) {
      for (int32_t i = 0; i < g.squares_x(level); ++i) {
        const int64_t sz = int64_t(1) << level;
        float worst = 0;
        for (int64_t y = j * sz; y <= j * sz + sz; ++y)
          for (int64_t x = i * sz; x <= i * sz + sz; ++x)
            worst = std::max(worst, std::abs(surface[size_t(y * cw + x)] - float(t.grid().at(x, y))));
        EXPECT_LE(worst, e.delta(level, i, j) + 1e-3f) << "level " << level << " square " << i << "," << j;
        if (level > 1) {
          EXPECT_GE(e.subtree(level, i, j), e.subtree(level - 1, 2 * i, 2 * j));
        }
      }
    }
  }
}

TEST(QuadtreeLod, RandomSubdivisionsMadeRestrictedAreWatertight) {
  std::mt19937 rng(5);
  const Terrain t = rough(200, 140, 5);
  for (int32_t block : {8, 32, 64}) {
    const QuadtreeGrid g = quadtree_grid_for(t, block);
    const QuadtreeErrors e = QuadtreeErrors::compute(g, t.grid());
    for (int round = 0; round < 5; ++round) {
      // A random camera with a random budget gives a different tree each round.
      std::uniform_real_distribution<double> u(-100, 500);
      QuadtreeState s(g);
      select_quadtree(g, e, kScale, view_at(u(rng), u(rng), 600 + u(rng), 0.5 + round), s);
      const lod::WatertightReport r = lod::check_watertight(replicate(g, s), g.covered());
      EXPECT_TRUE(r.ok()) << "block " << block << " round " << round << ": " << r.describe();
    }
  }
}

TEST(QuadtreeLod, TheDrawnSurfaceStaysWithinTheScreenErrorBudget) {
  const Terrain t = rough(257, 201, 9);
  const QuadtreeGrid g = quadtree_grid_for(t, 64);
  const QuadtreeErrors e = QuadtreeErrors::compute(g, t.grid());
  for (const LodView& v :
       {view_at(100, 100, 700, 1.0), view_at(400, 300, 1500, 4.0), view_at(-200, 50, 800, 2.0)}) {
    for (bool morph : {false, true}) {
      QuadtreeState s(g);
      const auto st = select_quadtree(g, e, kScale, v, s, morph);
      const double px = worst_screen_error(displayed_surface(g, t.grid(), s), g.covered().width(), t, v);
      std::printf(
          "tolerance %.1f px, morph %d: worst %.2f px, %lld triangles, %lld squares tested, %lld forced\n",
          v.tolerance_px, int(morph), px, static_cast<long long>(triangle_count(g, s)),
          static_cast<long long>(st.squares_tested), static_cast<long long>(st.forced));
      EXPECT_LE(px, v.tolerance_px) << "morph " << morph;
    }
  }
}

TEST(QuadtreeLod, GeomorphingBoundsTheSurfaceChangePerCameraStepWhereSubdivisionsJump) {
  const Terrain t = rough(257, 201, 13);
  const QuadtreeGrid g = quadtree_grid_for(t, 64);
  const QuadtreeErrors e = QuadtreeErrors::compute(g, t.grid());
  double max_step[2] = {0, 0};
  for (int morph = 0; morph < 2; ++morph) {
    QuadtreeState s(g);
    max_step[morph] = largest_surface_step(300, [&](const LodView& v) {
      select_quadtree(g, e, kScale, v, s, morph == 1);
      return displayed_surface(g, t.grid(), s);
    });
  }
  std::printf("largest surface change per 5 m camera step: %.3f m morphing, %.3f m without\n", max_step[1],
              max_step[0]);
  EXPECT_GT(max_step[0], 0.5);
  EXPECT_LT(max_step[1], 0.1 * max_step[0]);
}

TEST(QuadtreeLod, AStampRecomputesExactlyTheSquaresHoldingItsSamples) {
  Terrain t = rough(203, 150, 17);
  const QuadtreeGrid g = quadtree_grid_for(t, 32);
  QuadtreeErrors e = QuadtreeErrors::compute(g, t.grid());
  const RectI changed{90, 40, 120, 70};
  for (int64_t y = changed.y0; y < changed.y1; ++y)
    for (int64_t x = changed.x0; x < changed.x1; ++x)
      t.samples[size_t(y * t.width + x)] =
          uint16_t(15000 + 300 * std::hypot(double(x) - 105, double(y) - 55));
  const QuadtreeErrors before = e;
  const int64_t n = e.update(g, t.grid(), changed);
  const QuadtreeErrors fresh = QuadtreeErrors::compute(g, t.grid());
  int64_t touched = 0, differing = 0;
  for (int32_t l = 1; l <= g.levels; ++l) {
    const int64_t s = int64_t(1) << l;
    for (int32_t j = 0; j < g.squares_y(l); ++j) {
      for (int32_t i = 0; i < g.squares_x(l); ++i) {
        const bool holds = !RectI{i * s, j * s, i * s + s + 1, j * s + s + 1}.intersect(changed).empty();
        touched += holds;
        EXPECT_EQ(e.delta(l, i, j), fresh.delta(l, i, j));
        EXPECT_EQ(e.subtree(l, i, j), fresh.subtree(l, i, j));
        EXPECT_EQ(e.min_height(l, i, j), fresh.min_height(l, i, j));
        const bool differs = before.delta(l, i, j) != fresh.delta(l, i, j) ||
                             before.min_height(l, i, j) != fresh.min_height(l, i, j);
        differing += differs;
        if (differs) {
          EXPECT_TRUE(holds) << "level " << l << " square " << i << "," << j;
        }
      }
    }
  }
  EXPECT_EQ(n, touched);
  EXPECT_GT(differing, 0);
}

TEST(QuadtreeLod, OnlyBlocksWhoseSubdivisionChangedAreRebuilt) {
  const Terrain t = rough(257, 257, 19);
  const QuadtreeGrid g = quadtree_grid_for(t, 32);
  const QuadtreeErrors e = QuadtreeErrors::compute(g, t.grid());
  QuadtreeState s(g);
  // Without morphing a square's state changes only when it is subdivided or joined.
  select_quadtree(g, e, kScale, view_at(50, 50, 300, 2.0), s, false);
  s.clear_changed();
  const auto again = select_quadtree(g, e, kScale, view_at(50, 50, 300, 2.0), s, false);
  EXPECT_EQ(again.blocks_changed, 0) << "the same view changes nothing";
  const auto moved = select_quadtree(g, e, kScale, view_at(54, 52, 300, 2.0), s, false);
  EXPECT_GT(moved.blocks_changed, 0);
  EXPECT_LT(moved.blocks_changed, g.blocks_x * g.blocks_y) << "a small move rebuilds some blocks, not all";
  // A block's mesh uses its own vertices, each once, and a changed block's mesh is what the
  // replica draws there.
  std::vector<QuadtreeVertex> vertices;
  std::vector<std::array<uint32_t, 3>> triangles;
  int64_t total = 0;
  for (int32_t by = 0; by < g.blocks_y; ++by)
    for (int32_t bx = 0; bx < g.blocks_x; ++bx) {
      block_mesh(g, t.grid(), s, bx, by, vertices, triangles);
      total += int64_t(triangles.size());
      for (const auto& tri : triangles)
        for (uint32_t v : tri) ASSERT_LT(v, vertices.size());
    }
  EXPECT_EQ(total, triangle_count(g, s));
}

// Leitao & Carmo's tiled blocks, quadtree-based, crack correction by skirts: each block's
// quadtree restricted and drawn on its own, so the sides of neighbouring blocks differ, and each
// block's skirt reaches below the largest gap along its border; the budget still holds inside
// the blocks, and index updates (restriction across blocks) leave no gap at all.
TEST(TiledBlocks, QuadtreeBlocksOnTheirOwnCrackOnlyAsDeepAsTheirSkirtsReach) {
  const Terrain t = rough(300, 257, 23);
  for (int32_t block : {16, 32, 64}) {
    for (bool independent : {true, false}) {
      QuadtreeGrid g = quadtree_grid_for(t, block);
      g.independent_blocks = independent;
      const QuadtreeErrors e = QuadtreeErrors::compute(g, t.grid());
      int64_t cracked = 0;
      for (const LodView& v :
           {view_at(100, 100, 300, 8.0), view_at(500, 400, 900, 8.0), view_at(300, -50, 500, 2.0)}) {
        QuadtreeState s(g);
        select_quadtree(g, e, kScale, v, s);
        const std::vector<float> depth = quadtree_skirt_depths(g, e, s);
        double widest = 0;
        auto check = [&](int32_t bx, int32_t by, int32_t side, int32_t qx, int32_t qy, int32_t qside) {
          const auto a = block_side_profile(g, t.grid(), s, bx, by, side);
          const auto b = block_side_profile(g, t.grid(), s, qx, qy, qside);
          double gap = 0;
          for (size_t k = 0; k < a.size(); ++k) gap = std::max(gap, double(std::abs(a[k] - b[k])));
          cracked += gap > 1e-3;
          widest = std::max(widest, gap);
          const float reach =
              std::min(depth[size_t(by * g.blocks_x + bx)], depth[size_t(qy * g.blocks_x + qx)]);
          if (independent) {
            EXPECT_LE(gap, reach) << "block " << block << " at " << bx << "," << by;
          } else {
            EXPECT_LT(gap, 1e-3) << "block " << block << " at " << bx << "," << by;
          }
        };
        for (int32_t by = 0; by < g.blocks_y; ++by) {
          for (int32_t bx = 0; bx < g.blocks_x; ++bx) {
            if (bx + 1 < g.blocks_x) check(bx, by, kSideRight, bx + 1, by, kSideLeft);
            if (by + 1 < g.blocks_y) check(bx, by, kSideBottom, bx, by + 1, kSideTop);
          }
        }
        if (independent) {
          const double px = worst_screen_error(displayed_surface(g, t.grid(), s), g.covered().width(), t, v);
          std::printf("block %d, %.0f px: widest gap %.0f units, worst %.2f px, %lld triangles\n", block,
                      v.tolerance_px, widest, px, static_cast<long long>(triangle_count(g, s)));
          EXPECT_LE(px, v.tolerance_px);
        }
      }
      if (independent) {
        EXPECT_GT(cracked, 0) << "block " << block << ": blocks on their own do crack";
      }
    }
  }
}

}  // namespace
}  // namespace loam::lod
