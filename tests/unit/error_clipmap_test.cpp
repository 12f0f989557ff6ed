// The error-driven clipmap (client/lod/error_clipmap.h) on its CPU replica: block errors that
// bound every level's surface (exact below exact_levels, a sound bound above), selections that
// are watertight and restricted from low and high cameras with regions centred on the camera,
// blocks used only inside their level's region, the screen-error budget met, geomorphing that
// bounds the surface change per camera step, and a stamp that recomputes exactly the blocks
// holding its samples. Worlds of odd sizes, rough and flat.
#include "client/lod/error_clipmap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>
#include <string>

#include "lod_test_terrain.h"

namespace loam::lod {
namespace {

using namespace test;

ClipmapBlockGrid grid_for(const Terrain& t, int32_t block_size, int32_t levels) {
  auto g = ClipmapBlockGrid::make(t.width, t.height, block_size, levels);
  EXPECT_TRUE(g.ok()) << g.error().describe();
  return *g;
}

// Mip l of a terrain: every 2^l-th sample, clamped at the world's edge as mip 0 is.
MipReader reader(const Terrain& t) {
  return [&t](int32_t mip, const RectI& r, std::span<uint16_t> out) {
    const HeightGrid h = t.grid();
    size_t i = 0;
    for (int64_t y = r.y0; y < r.y1; ++y)
      for (int64_t x = r.x0; x < r.x1; ++x) out[i++] = h.at(x << mip, y << mip);
  };
}

// Level regions of `size` level samples centred on the view, as the renderer places them.
std::vector<RectI> regions_around(const ClipmapBlockGrid& g, const LodView& v, int64_t size) {
  std::vector<RectI> out;
  for (int32_t l = 0; l < g.levels; ++l) {
    const double s = double(int64_t(1) << l) * kScale.meters_per_sample;
    const int64_t cx = int64_t(std::floor(v.x / s)) - size / 2, cy = int64_t(std::floor(v.y / s)) - size / 2;
    out.push_back({cx, cy, cx + size, cy + size});
  }
  return out;
}

std::vector<RectI> everywhere(const ClipmapBlockGrid& g) {
  return std::vector<RectI>(size_t(g.levels), RectI{0, 0, int64_t(1) << 40, int64_t(1) << 40});
}

// The largest |height - level-l surface| over a block's world samples, by brute force.
double brute_error(const Terrain& t, const ClipmapBlockGrid& g, int32_t l, int64_t bx, int64_t by) {
  const HeightGrid h = t.grid();
  const int64_t s = int64_t(1) << l;
  double worst = 0;
  const RectI r = g.block_rect(l, bx, by);
  for (int64_t y = r.y0; y < std::min(r.y1, t.height); ++y) {
    for (int64_t x = r.x0; x < std::min(r.x1, t.width); ++x) {
      const int64_t qx = std::min(x / s * s, r.x1 - 1 - s), qy = std::min(y / s * s, r.y1 - 1 - s);
      const double surface = union_jack_surface(
          h.at(qx, qy), h.at(qx + s, qy), h.at(qx, qy + s), h.at(qx + s, qy + s), double(x - qx) / double(s),
          double(y - qy) / double(s), union_jack_main_diagonal(qx, qy, s));
      worst = std::max(worst, std::abs(double(h.at(x, y)) - surface));
    }
  }
  return worst;
}

TEST(ErrorClipmap, BlockSizesAndLevelsAreChecked) {
  EXPECT_FALSE(ClipmapBlockGrid::make(100, 100, 16, 4).ok());
  EXPECT_FALSE(ClipmapBlockGrid::make(100, 100, 129, 4).ok());
  EXPECT_FALSE(ClipmapBlockGrid::make(100, 100, 17, 0).ok());
  EXPECT_FALSE(ClipmapBlockGrid::make(1, 100, 17, 4).ok());
  const auto g = ClipmapBlockGrid::make(300, 221, 17, 5);
  ASSERT_TRUE(g.ok());
  EXPECT_EQ(g->span(2), 64);
  EXPECT_EQ(g->blocks_x(0), 19);  // 299 / 16 rounded up
  EXPECT_EQ(g->blocks_y(4), 1);
}

TEST(ErrorClipmap, BlockErrorsAreExactBelowTheExactLevelsAndASoundBoundAbove) {
  const Terrain t = rough(300, 221, 3);
  const ClipmapBlockGrid g = grid_for(t, 17, 5);
  const ClipmapErrorPyramid exact = ClipmapErrorPyramid::compute(g, reader(t), 10);
  const ClipmapErrorPyramid chained = ClipmapErrorPyramid::compute(g, reader(t), 1);
  double loosest = 1;
  for (int32_t l = 1; l < g.levels; ++l) {
    for (int32_t by = 0; by < g.blocks_y(l); ++by) {
      for (int32_t bx = 0; bx < g.blocks_x(l); ++bx) {
        const double brute = brute_error(t, g, l, bx, by);
        EXPECT_GE(double(exact.error(l, bx, by)), brute) << l << " " << bx << "," << by;
        EXPECT_GE(chained.error(l, bx, by), exact.error(l, bx, by)) << l << " " << bx << "," << by;
        EXPECT_GE(exact.error(l, bx, by), exact.error(l - 1, 2 * bx, 2 * by))
            << "a parent bounds its children";
        EXPECT_EQ(exact.min_height(l, bx, by), chained.min_height(l, bx, by));
        EXPECT_EQ(exact.max_height(l, bx, by), chained.max_height(l, bx, by));
        if (exact.error(l, bx, by) > 0)
          loosest = std::max(loosest, double(chained.error(l, bx, by) / exact.error(l, bx, by)));
      }
    }
  }
  std::printf("chained bound at most %.2f x the exact error\n", loosest);
  const Terrain f = flat(97, 70);
  const ClipmapBlockGrid gf = grid_for(f, 17, 4);
  const ClipmapErrorPyramid pf = ClipmapErrorPyramid::compute(gf, reader(f), 1);
  for (int32_t l = 0; l < gf.levels; ++l) EXPECT_EQ(pf.error(l, 0, 0), 0.0f);
}

TEST(ErrorClipmap, SelectionsAreWatertightAndUseBlocksOnlyInsideTheirLevelsRegion) {
  const Terrain t = rough(513, 401, 7);
  for (int32_t n : {9, 17}) {
    const ClipmapBlockGrid g = grid_for(t, n, 7);
    const ClipmapErrorPyramid e = ClipmapErrorPyramid::compute(g, reader(t));
    for (const LodView& v : {view_at(10, 10, 400, 1.0), view_at(500, 400, 2500), view_at(-300, 100, 3000),
                             view_at(512, 300, 600, 0.5), view_at(200, 700, 1200, 4.0)}) {
      for (int64_t size : {int64_t(8 * n), int64_t(160)}) {
        const std::vector<RectI> regions = regions_around(g, v, size);
        const ErrorClipmapSelection sel = select_error_clipmap(g, e, kScale, v, regions);
        std::map<int, int> levels;
        for (const ClipmapBlock& b : sel.blocks) {
          ++levels[b.id.level];
          const int64_t c = g.cells();
          const RectI local{b.id.bx * c, b.id.by * c, b.id.bx * c + c + 1, b.id.by * c + c + 1};
          EXPECT_EQ(local.intersect(regions[size_t(b.id.level)]), local)
              << "a block outside its level's region";
        }
        EXPECT_GT(levels.size(), 2u) << "a view that mixes levels";
        EXPECT_EQ(sel.stats.unrestricted, 0);
        const lod::WatertightReport r = lod::check_watertight(replicate(g, sel), sel.covered);
        EXPECT_TRUE(r.ok()) << "block " << n << " region " << size << ": " << r.describe();
      }
    }
  }
}

TEST(ErrorClipmap, BlocksAFilterRejectsStayWholeAndTheMeshStaysWatertight) {
  const Terrain t = rough(513, 401, 8);
  const ClipmapBlockGrid g = grid_for(t, 9, 7);
  const ClipmapErrorPyramid e = ClipmapErrorPyramid::compute(g, reader(t));
  const LodView v = view_at(500, 400, 300, 1.0);
  // As a frustum looking toward +x would: nothing wholly west of the eye is split.
  const BlockFilter east = [&](int32_t l, int64_t bx, int64_t) {
    return double((bx + 1) * g.span(l)) * kScale.meters_per_sample >= v.x;
  };
  const ErrorClipmapSelection all = select_error_clipmap(g, e, kScale, v, everywhere(g));
  const ErrorClipmapSelection half = select_error_clipmap(g, e, kScale, v, everywhere(g), true, east);
  EXPECT_LT(half.blocks.size(), all.blocks.size());
  EXPECT_EQ(half.stats.unrestricted, 0);
  const lod::WatertightReport r = lod::check_watertight(replicate(g, half), half.covered);
  EXPECT_TRUE(r.ok()) << r.describe();
  // East of the eye, beyond the restriction's reach of the filter's edge, the blocks are the same.
  std::set<ClipmapBlockId> east_all, east_half;
  for (const ClipmapBlock& b : all.blocks)
    if (double(b.id.bx * g.span(b.id.level)) * kScale.meters_per_sample >= v.x + 600) east_all.insert(b.id);
  for (const ClipmapBlock& b : half.blocks)
    if (double(b.id.bx * g.span(b.id.level)) * kScale.meters_per_sample >= v.x + 600) east_half.insert(b.id);
  EXPECT_EQ(east_all, east_half);
}

TEST(ErrorClipmap, TheDrawnSurfaceStaysWithinTheScreenErrorBudget) {
  const Terrain t = rough(257, 201, 9);
  const ClipmapBlockGrid g = grid_for(t, 17, 5);
  for (int32_t exact_levels : {1, 8}) {
    const ClipmapErrorPyramid e = ClipmapErrorPyramid::compute(g, reader(t), exact_levels);
    for (const LodView& v :
         {view_at(100, 100, 700, 1.0), view_at(400, 300, 1500, 4.0), view_at(-200, 50, 800, 2.0)}) {
      for (bool morph : {false, true}) {
        const ErrorClipmapSelection sel = select_error_clipmap(g, e, kScale, v, everywhere(g), morph);
        double vertical = 0;
        const double px =
            worst_screen_error(displayed_surface(g, t.grid(), sel), sel.covered.width(), t, v, &vertical);
        std::printf("exact levels %d, tolerance %.1f px, morph %d: worst %.2f px (%.2f m), %lld triangles\n",
                    exact_levels, v.tolerance_px, int(morph), px, vertical,
                    static_cast<long long>(triangle_count(g, sel)));
        EXPECT_EQ(sel.stats.held_back, 0);
        // As geomipmapping: a side toward a coarser neighbour interpolates between the levels.
        EXPECT_LE(px, 1.5 * v.tolerance_px) << "morph " << morph;
      }
    }
  }
}

TEST(ErrorClipmap, ABlockCapHoldsTheBudgetsSplitsAndRaisesTheBudgetToTheErrorLeftWhole) {
  // The roots' blocks end at the world's edge: none reaches past it (a leaf beside one that
  // does fans its side along the world's last row toward it).
  const Terrain t = rough(513, 513, 8);
  const ClipmapBlockGrid g = grid_for(t, 9, 7);
  const ClipmapErrorPyramid e = ClipmapErrorPyramid::compute(g, reader(t));
  const LodView v = view_at(300, 250, 1500, 1.0);
  const ErrorClipmapSelection all = select_error_clipmap(g, e, kScale, v, everywhere(g));
  EXPECT_FALSE(all.stats.budget_bound);
  EXPECT_EQ(all.stats.tolerance_px, 1.0);
  const int64_t roots = int64_t(g.blocks_x(g.levels - 1)) * g.blocks_y(g.levels - 1);
  // A cap the view's budget does not reach changes nothing.
  const ErrorClipmapSelection roomy =
      select_error_clipmap(g, e, kScale, v, everywhere(g), true, {}, int64_t(all.blocks.size()) + 100);
  EXPECT_FALSE(roomy.stats.budget_bound);
  ASSERT_EQ(roomy.blocks.size(), all.blocks.size());
  for (size_t i = 0; i < all.blocks.size(); ++i) EXPECT_EQ(roomy.blocks[i].id, all.blocks[i].id);
  for (const int64_t cap : {int64_t(all.blocks.size()) / 2, int64_t(all.blocks.size()) / 8}) {
    const ErrorClipmapSelection capped = select_error_clipmap(g, e, kScale, v, everywhere(g), true, {}, cap);
    EXPECT_TRUE(capped.stats.budget_bound);
    // Each split makes three more leaves: the budget's within the cap, the restriction's on top.
    EXPECT_LE(roots + 3 * capped.stats.split, cap);
    EXPECT_GT(roots + 3 * capped.stats.split, cap - 3);
    EXPECT_EQ(int64_t(capped.blocks.size()), roots + 3 * (capped.stats.split + capped.stats.forced));
    EXPECT_GT(capped.stats.tolerance_px, v.tolerance_px);
    const lod::WatertightReport r = lod::check_watertight(replicate(g, capped), capped.covered);
    EXPECT_TRUE(r.ok()) << r.describe();
    // The drawn surface meets the raised budget as the view's is met uncapped (sides toward a
    // coarser neighbour interpolate between the levels).
    const double px =
        worst_screen_error(displayed_surface(g, t.grid(), capped), capped.covered.width(), t, v);
    std::printf("cap %lld blocks: %zu drawn, budget raised to %.2f px, worst %.2f px\n",
                static_cast<long long>(cap), capped.blocks.size(), capped.stats.tolerance_px, px);
    EXPECT_LE(px, 1.5 * capped.stats.tolerance_px);
    EXPECT_GT(px, v.tolerance_px);  // the cap cost accuracy: it bound
  }
}

TEST(ErrorClipmap, FlatTerrainIsDrawnByTheCoarsestBlocksAlone) {
  const Terrain t = flat(257, 257);
  const ClipmapBlockGrid g = grid_for(t, 17, 5);
  const ClipmapErrorPyramid e = ClipmapErrorPyramid::compute(g, reader(t));
  const ErrorClipmapSelection sel =
      select_error_clipmap(g, e, kScale, view_at(128, 128, 20, 0.25), everywhere(g));
  for (const ClipmapBlock& b : sel.blocks) EXPECT_EQ(b.id.level, 4);
  EXPECT_EQ(sel.blocks.size(), 1u);
}

TEST(ErrorClipmap, GeomorphingBoundsTheSurfaceChangePerCameraStepWhereSplitsJump) {
  const Terrain t = rough(257, 201, 13);
  const ClipmapBlockGrid g = grid_for(t, 17, 5);
  const ClipmapErrorPyramid e = ClipmapErrorPyramid::compute(g, reader(t));
  double max_step[2] = {0, 0};
  for (int morph = 0; morph < 2; ++morph) {
    // From 500 m to 1.5 km.
    max_step[morph] = largest_surface_step(200, [&](const LodView& v) {
      return displayed_surface(g, t.grid(), select_error_clipmap(g, e, kScale, v, everywhere(g), morph == 1));
    });
  }
  std::printf("largest surface change per 5 m camera step: %.3f m morphing, %.3f m without\n", max_step[1],
              max_step[0]);
  // Splits and merges without morphing jump by a level's error; with it, only the morph
  // factors move, continuously (measured over 300 steps: 0.20 m against 1.35 m).
  EXPECT_GT(max_step[0], 0.5);
  EXPECT_LT(max_step[1], 0.25);
  EXPECT_LT(max_step[1], 0.2 * max_step[0]);
}

TEST(ErrorClipmap, AStampRecomputesExactlyTheBlocksHoldingItsSamples) {
  Terrain t = rough(203, 150, 17);
  const ClipmapBlockGrid g = grid_for(t, 17, 5);
  ClipmapErrorPyramid e = ClipmapErrorPyramid::compute(g, reader(t), 2);
  const RectI changed{90, 40, 120, 70};
  for (int64_t y = changed.y0; y < changed.y1; ++y) {
    for (int64_t x = changed.x0; x < changed.x1; ++x) {
      const double r = std::hypot(double(x) - 105, double(y) - 55);
      t.samples[size_t(y * t.width + x)] = uint16_t(std::max(0.0, 15000 - 400 * (15 - r)));
    }
  }
  const ClipmapErrorPyramid before = e;
  const auto updated = e.update(g, reader(t), changed);
  const ClipmapErrorPyramid fresh = ClipmapErrorPyramid::compute(g, reader(t), 2);
  std::set<ClipmapBlockId> touched;
  int changed_blocks = 0;
  for (int32_t l = 0; l < g.levels; ++l) {
    for (int32_t by = 0; by < g.blocks_y(l); ++by) {
      for (int32_t bx = 0; bx < g.blocks_x(l); ++bx) {
        if (!g.block_rect(l, bx, by).intersect(changed).empty()) touched.insert({l, bx, by});
        EXPECT_EQ(e.error(l, bx, by), fresh.error(l, bx, by));
        EXPECT_EQ(e.min_height(l, bx, by), fresh.min_height(l, bx, by));
        EXPECT_EQ(e.max_height(l, bx, by), fresh.max_height(l, bx, by));
        if (before.error(l, bx, by) != fresh.error(l, bx, by) ||
            before.min_height(l, bx, by) != fresh.min_height(l, bx, by)) {
          ++changed_blocks;
          EXPECT_TRUE(touched.count({l, bx, by}))
              << "block " << l << " " << bx << "," << by << " changed untouched";
        }
      }
    }
  }
  EXPECT_EQ(std::set<ClipmapBlockId>(updated.begin(), updated.end()), touched);
  EXPECT_EQ(updated.size(), touched.size()) << "each touched block once";
  EXPECT_GT(changed_blocks, 0);
  // [90, 120) x [40, 70): 9 level-0 blocks (80..128 by 32..80), 4 at level 1, 2 at 2, 1 at 3 and 4.
  std::map<int32_t, int> per_level;
  for (const ClipmapBlockId& b : updated) ++per_level[b.level];
  EXPECT_EQ(per_level[0], 9);
  EXPECT_EQ(per_level[1], 4);
  EXPECT_EQ(per_level[4], 1);
}

std::vector<RectI> windows_for(const ClipmapBlockGrid& g, const std::vector<RectI>& regions) {
  std::vector<RectI> out;
  for (int32_t l = 0; l < g.levels; ++l) out.push_back(blocks_inside(g, l, regions[size_t(l)]));
  return out;
}

void expect_same_in_windows(const ClipmapErrorPyramid& a, const ClipmapErrorPyramid& b, int32_t levels,
                            const char* where) {
  for (int32_t l = 0; l < levels; ++l) {
    ASSERT_EQ(a.window(l), b.window(l)) << where << ", level " << l;
    const RectI w = a.window(l);
    for (int64_t by = w.y0; by < w.y1; ++by) {
      for (int64_t bx = w.x0; bx < w.x1; ++bx) {
        ASSERT_EQ(a.error(l, bx, by), b.error(l, bx, by))
            << where << ", block " << l << " " << bx << "," << by;
        ASSERT_EQ(a.min_height(l, bx, by), b.min_height(l, bx, by)) << where;
        ASSERT_EQ(a.max_height(l, bx, by), b.max_height(l, bx, by)) << where;
      }
    }
  }
}

TEST(ErrorClipmap, WindowsMovedAlongAPathHoldWhatAFreshWindowedPyramidComputes) {
  const Terrain t = rough(611, 389, 21);
  const ClipmapBlockGrid g = grid_for(t, 9, 6);
  ClipmapErrorPyramid moving = ClipmapErrorPyramid::windowed(g, 2);
  int64_t window_blocks = 0, computed_after_first = 0, moves = 0;
  for (int step = 0; step < 24; ++step) {
    // A walk with a jump back: windows slide by parts of a block, by several, and back.
    const double x = step == 17 ? 60.0 : 100.0 + 37.0 * step, y = 90.0 + 11.0 * step;
    const std::vector<RectI> windows = windows_for(g, regions_around(g, view_at(x, y, 300), 120));
    const int64_t computed = moving.move_windows(g, reader(t), windows);
    EXPECT_EQ(moving.move_windows(g, reader(t), windows), 0) << "a camera that stayed computes nothing";
    ClipmapErrorPyramid fresh = ClipmapErrorPyramid::windowed(g, 2);
    const int64_t all = fresh.move_windows(g, reader(t), windows);
    expect_same_in_windows(moving, fresh, g.levels, ("step " + std::to_string(step)).c_str());
    EXPECT_LE(computed, all);
    if (step > 0 && step != 17) computed_after_first += computed, window_blocks += all, ++moves;
  }
  // A slide recomputes the strips that entered and the coarser blocks over them, not the windows.
  EXPECT_LT(computed_after_first, window_blocks / 2) << moves << " moves";
}

TEST(ErrorClipmap, WindowedBoundsMatchTheWholeWorldsWhereTheFinerWindowsHoldEveryChild) {
  const Terrain t = rough(513, 401, 23);
  const ClipmapBlockGrid g = grid_for(t, 9, 6);
  const ClipmapErrorPyramid whole = ClipmapErrorPyramid::compute(g, reader(t), 2);
  ClipmapErrorPyramid win = ClipmapErrorPyramid::windowed(g, 2);
  win.move_windows(g, reader(t), windows_for(g, regions_around(g, view_at(400, 300, 300), 136)));
  // Which blocks have their whole subtree inside the finer windows.
  std::vector<std::set<std::pair<int64_t, int64_t>>> complete(size_t(g.levels));
  int64_t compared = 0, partial = 0;
  for (int32_t l = 0; l < g.levels; ++l) {
    const RectI w = win.window(l);
    for (int64_t by = w.y0; by < w.y1; ++by) {
      for (int64_t bx = w.x0; bx < w.x1; ++bx) {
        bool all = true;
        for (int64_t j = 0; j < 2 && l > 0; ++j)
          for (int64_t i = 0; i < 2; ++i) {
            const int64_t cx = 2 * bx + i, cy = 2 * by + j;
            const bool exists = cx < g.blocks_x(l - 1) && cy < g.blocks_y(l - 1);
            all = all && (!exists || complete[size_t(l - 1)].count({cx, cy}) > 0);
          }
        if (!all) {
          // The finest the viewer can draw there is level l - 1: the bound covers that surface.
          ++partial;
          EXPECT_LE(win.error(l, bx, by), whole.error(l, bx, by));
          EXPECT_LE(win.min_height(l, bx, by), win.max_height(l, bx, by));
          continue;
        }
        complete[size_t(l)].insert({bx, by});
        ++compared;
        EXPECT_EQ(win.error(l, bx, by), whole.error(l, bx, by)) << l << " " << bx << "," << by;
        EXPECT_EQ(win.min_height(l, bx, by), whole.min_height(l, bx, by));
        EXPECT_EQ(win.max_height(l, bx, by), whole.max_height(l, bx, by));
      }
    }
  }
  EXPECT_GT(compared, 200);
  EXPECT_GT(partial, 10);
}

TEST(ErrorClipmap, AWorldOfAHundredKilometresCostsWhatItsRegionsHold) {
  // 131072 x 98304 samples (the refined default world's size), heights made on demand.
  auto g = ClipmapBlockGrid::make(131072, 98304, 9, 15);
  ASSERT_TRUE(g.ok());
  const MipReader procedural = [](int32_t mip, const RectI& r, std::span<uint16_t> out) {
    size_t i = 0;
    for (int64_t y = r.y0; y < r.y1; ++y)
      for (int64_t x = r.x0; x < r.x1; ++x) {
        const uint64_t gx = uint64_t(x) << mip, gy = uint64_t(y) << mip;
        out[i++] = uint16_t(20000 + (gx * 7 + gy * 13) % 997 + ((gx * 2654435761u) ^ (gy * 40503u)) % 31);
      }
  };
  ClipmapErrorPyramid e = ClipmapErrorPyramid::windowed(*g, 1);
  const LodView v =
      view_at(131072.0 * kScale.meters_per_sample / 2, 98304.0 * kScale.meters_per_sample / 3, 500);
  const int64_t region = 256;
  const std::vector<RectI> regions = regions_around(*g, v, region);
  const int64_t computed = e.move_windows(*g, procedural, windows_for(*g, regions));
  // At most (region / cells)^2 blocks a level: nothing scales with the world.
  const int64_t per_level = (region / g->cells()) * (region / g->cells());
  EXPECT_LE(computed, per_level * g->levels);
  EXPECT_LE(e.bytes(), size_t(per_level * g->levels) * 8);
  const ErrorClipmapSelection sel = select_error_clipmap(*g, e, kScale, v, regions);
  EXPECT_GT(sel.blocks.size(), 100u);
  EXPECT_EQ(sel.stats.unrestricted, 0);
  // The camera moves a block's width: only the entering strips are computed.
  const LodView w = view_at(v.x + 8 * kScale.meters_per_sample, v.y, v.z);
  const int64_t moved = e.move_windows(*g, procedural, windows_for(*g, regions_around(*g, w, region)));
  EXPECT_GT(moved, 0);
  EXPECT_LT(moved, computed / 4);
}
}  // namespace
}  // namespace loam::lod
