// Geomipmapping (client/lod/geomipmap.h) on its CPU replica: per-patch level errors that bound
// the drawn surface, watertight meshes whatever the neighbours' levels, vertices shared by two
// patches drawn at the same height, geomorphing that bounds the surface change per camera
// step, the screen-error budget met at every sample, and a stamp that updates the error bounds
// of exactly the patches it touches. Worlds of odd sizes, rough, ridged and flat.
#include "client/lod/geomipmap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <set>

#include "lod_test_terrain.h"

namespace loam::lod {
namespace {

using namespace test;

GeomipmapGrid grid_for(const Terrain& t, int32_t patch_size) {
  auto g = GeomipmapGrid::make(t.width, t.height, patch_size);
  EXPECT_TRUE(g.ok()) << g.error().describe();
  return *g;
}

TEST(Geomipmap, PatchSizesMustBeAPowerOfTwoPlusOneAndPatchesCoverTheWorld) {
  EXPECT_FALSE(GeomipmapGrid::make(100, 100, 16).ok());
  EXPECT_FALSE(GeomipmapGrid::make(100, 100, 3).ok());
  EXPECT_FALSE(GeomipmapGrid::make(100, 100, 257).ok());
  EXPECT_FALSE(GeomipmapGrid::make(1, 100, 17).ok());
  for (int32_t n : {5, 17, 33, 65, 129}) {
    auto g = GeomipmapGrid::make(203, 150, n);
    ASSERT_TRUE(g.ok()) << n;
    EXPECT_EQ(1 << (g->levels - 1), n - 1);
    EXPECT_GE(g->covered().x1, 203);
    EXPECT_GE(g->covered().y1, 150);
    EXPECT_LT(g->covered().x1 - 203, n - 1);  // no patch wholly outside
  }
}

TEST(Geomipmap, LevelErrorsBoundTheSurfaceDrawnAtThatLevelAndGrowWithTheLevel) {
  for (int32_t n : {9, 17, 33}) {
    const Terrain t = rough(203, 150, 3);
    const GeomipmapGrid g = grid_for(t, n);
    const GeomipmapErrors e = GeomipmapErrors::compute(g, t.grid());
    for (int32_t level = 0; level < g.levels; ++level) {
      std::vector<PatchLod> lods(size_t(g.patch_count()));
      for (PatchLod& p : lods) p.level = int8_t(level);
      assign_sides(g, lods);
      const std::vector<float> surface = displayed_surface(g, t.grid(), lods);
      const int64_t cw = g.covered().width();
      double worst_ratio = 0;
      for (int32_t py = 0; py < g.patches_y; ++py) {
        for (int32_t px = 0; px < g.patches_x; ++px) {
          const float bound = e.error(px, py, level);
          if (level > 0) {
            EXPECT_GE(bound, e.error(px, py, level - 1));
          } else {
            EXPECT_EQ(bound, 0.0f);
          }
          const RectI r = g.patch_rect(px, py);
          float worst = 0;
          for (int64_t y = r.y0; y < r.y1; ++y)
            for (int64_t x = r.x0; x < r.x1; ++x)
              worst = std::max(worst, std::abs(surface[size_t(y * cw + x)] - float(t.grid().at(x, y))));
          EXPECT_LE(worst, bound + 1e-3f) << "patch " << px << "," << py << " level " << level;
          if (bound > 0) worst_ratio = std::max(worst_ratio, double(worst) / double(bound));
        }
      }
      // The bound is the drawn error itself, not a loose one.
      if (level > 0) {
        EXPECT_GT(worst_ratio, 0.99) << "n " << n << " level " << level;
      }
    }
  }
}

TEST(Geomipmap, FlatTerrainHasNoErrorAndIsDrawnAtTheCoarsestLevel) {
  const Terrain t = flat(130, 77);
  const GeomipmapGrid g = grid_for(t, 17);
  const GeomipmapErrors e = GeomipmapErrors::compute(g, t.grid());
  const auto lods = select_lods(g, e, kScale, view_at(50, 50, 1));
  for (const PatchLod& p : lods) {
    EXPECT_EQ(p.level, g.levels - 1);
    EXPECT_EQ(p.morph, 0.0f);
  }
  EXPECT_EQ(triangle_count(g, lods), 2 * g.patch_count());
}

// Random levels per patch, so neighbours differ by up to the whole level range.
std::vector<PatchLod> random_lods(const GeomipmapGrid& g, std::mt19937& rng) {
  std::vector<PatchLod> lods(size_t(g.patch_count()));
  for (PatchLod& p : lods) {
    p.level = int8_t(rng() % uint32_t(g.levels));
    p.morph = float(rng() % 100) / 100.0f;
    if (p.level == g.levels - 1) p.morph = 0;
  }
  assign_sides(g, lods);
  return lods;
}

// Every vertex position drawn by several patches gets the same height from each.
int64_t height_disagreements(const GeomipmapGrid& g, const HeightGrid& h, const std::vector<PatchLod>& lods) {
  std::map<std::pair<int64_t, int64_t>, float> seen;
  int64_t bad = 0;
  const int32_t c = g.cells(), n = g.patch_size;
  for (int32_t py = 0; py < g.patches_y; ++py) {
    for (int32_t px = 0; px < g.patches_x; ++px) {
      const PatchLod& lod = lods[size_t(py * g.patches_x + px)];
      for (const auto& tri : patch_triangles(g, lod.level, lod.edge_level)) {
        for (uint16_t v : tri) {
          const int32_t lx = v % n, ly = v / n;
          const float z = displayed_height(g, h, px, py, lod, lx, ly);
          const auto [it, fresh] = seen.try_emplace({int64_t(px) * c + lx, int64_t(py) * c + ly}, z);
          if (!fresh && it->second != z) ++bad;
        }
      }
    }
  }
  return bad;
}

TEST(Geomipmap, MeshesAreWatertightAndSharedVerticesAgreeWhateverTheNeighboursLevels) {
  std::mt19937 rng(11);
  for (int32_t n : {5, 9, 17, 33, 65}) {
    const Terrain t = rough(n == 65 ? 300 : 181, 133, 5);
    const GeomipmapGrid g = grid_for(t, n);
    for (int round = 0; round < 6; ++round) {
      const auto lods = random_lods(g, rng);
      const lod::WatertightReport r = lod::check_watertight(replicate(g, lods), g.covered());
      EXPECT_TRUE(r.ok()) << "patch size " << n << " round " << round << ": " << r.describe();
      EXPECT_EQ(height_disagreements(g, t.grid(), lods), 0) << "patch size " << n << " round " << round;
    }
  }
}

TEST(Geomipmap, SelectedMeshesAreWatertightFromLowAndHighCameras) {
  const Terrain t = rough(257, 201, 7);
  const GeomipmapGrid g = grid_for(t, 17);
  const GeomipmapErrors e = GeomipmapErrors::compute(g, t.grid());
  for (const LodView& v : {view_at(10, 10, 900, 4.0), view_at(250, 200, 2500), view_at(-300, 100, 3000),
                           view_at(256, 200, 5000, 8.0), view_at(100, 300, 1200, 4.0)}) {
    const auto lods = select_lods(g, e, kScale, v);
    std::map<int, int> levels;
    for (const PatchLod& p : lods) ++levels[p.level];
    EXPECT_GT(levels.size(), 1u) << "a camera that sees several levels, at " << v.x << "," << v.y << ","
                                 << v.z;
    const lod::WatertightReport r = lod::check_watertight(replicate(g, lods), g.covered());
    EXPECT_TRUE(r.ok()) << r.describe();
    EXPECT_EQ(height_disagreements(g, t.grid(), lods), 0);
  }
}

TEST(Geomipmap, TheDrawnSurfaceStaysWithinTheScreenErrorBudget) {
  const Terrain t = rough(257, 201, 9);
  for (int32_t n : {17, 33}) {
    const GeomipmapGrid g = grid_for(t, n);
    const GeomipmapErrors e = GeomipmapErrors::compute(g, t.grid());
    for (const LodView& v :
         {view_at(100, 100, 700, 1.0), view_at(400, 300, 1500, 4.0), view_at(-200, 50, 800, 2.0)}) {
      for (bool morph : {false, true}) {
        const auto lods = select_lods(g, e, kScale, v, morph);
        double vertical = 0;
        const double px =
            worst_screen_error(displayed_surface(g, t.grid(), lods), g.covered().width(), t, v, &vertical);
        std::printf("patch %d, tolerance %.1f px, morph %d: worst %.2f px (%.2f m), %lld triangles\n", n,
                    v.tolerance_px, int(morph), px, vertical,
                    static_cast<long long>(triangle_count(g, lods)));
        // Where a patch meets a coarser neighbour its border strip interpolates between the two
        // levels: the budget holds up to that seam's share.
        EXPECT_LE(px, 1.5 * v.tolerance_px) << "patch " << n << " morph " << morph;
      }
    }
  }
}

TEST(Geomipmap, GeomorphingBoundsTheSurfaceChangePerCameraStepWhereLevelSwitchesJump) {
  const Terrain t = rough(257, 201, 13);
  const GeomipmapGrid g = grid_for(t, 17);
  const GeomipmapErrors e = GeomipmapErrors::compute(g, t.grid());
  double max_step[2] = {0, 0};
  for (int morph = 0; morph < 2; ++morph) {
    max_step[morph] = largest_surface_step(300, [&](const LodView& v) {
      return displayed_surface(g, t.grid(), select_lods(g, e, kScale, v, morph == 1));
    });
  }
  std::printf("largest surface change per 5 m camera step: %.3f m morphing, %.3f m without\n", max_step[1],
              max_step[0]);
  EXPECT_GT(max_step[0], 0.5);                // level switches without morphing jump
  EXPECT_LT(max_step[1], 0.1 * max_step[0]);  // measured: 0.23 m against 4.6 m
}

TEST(Geomipmap, AStampUpdatesTheErrorBoundsOfExactlyThePatchesItTouches) {
  Terrain t = rough(203, 150, 17);
  const GeomipmapGrid g = grid_for(t, 17);
  GeomipmapErrors e = GeomipmapErrors::compute(g, t.grid());
  // A crater over a patch corner: [90, 120) x [40, 70) crosses patches 5..7 by 2..4.
  const RectI changed{90, 40, 120, 70};
  for (int64_t y = changed.y0; y < changed.y1; ++y) {
    for (int64_t x = changed.x0; x < changed.x1; ++x) {
      const double r = std::hypot(double(x) - 105, double(y) - 55);
      t.samples[size_t(y * t.width + x)] = uint16_t(std::max(0.0, 15000 - 400 * (15 - r)));
    }
  }
  const GeomipmapErrors before = e;
  const auto updated = e.update(g, t.grid(), changed);
  const GeomipmapErrors fresh = GeomipmapErrors::compute(g, t.grid());
  std::set<std::array<int32_t, 2>> touched;
  for (int32_t py = 0; py < g.patches_y; ++py)
    for (int32_t px = 0; px < g.patches_x; ++px)
      if (!g.patch_rect(px, py).intersect(changed).empty()) touched.insert({px, py});
  using Patches = std::set<std::array<int32_t, 2>>;
  EXPECT_EQ(Patches(updated.begin(), updated.end()), touched);
  EXPECT_EQ(updated.size(), touched.size()) << "each touched patch once";
  EXPECT_EQ(touched.size(), 9u);
  int changed_patches = 0;
  for (int32_t py = 0; py < g.patches_y; ++py) {
    for (int32_t px = 0; px < g.patches_x; ++px) {
      bool differs = before.min_height(px, py) != fresh.min_height(px, py);
      for (int32_t l = 0; l < g.levels; ++l) {
        EXPECT_EQ(e.error(px, py, l), fresh.error(px, py, l));
        differs = differs || before.error(px, py, l) != fresh.error(px, py, l);
      }
      EXPECT_EQ(e.min_height(px, py), fresh.min_height(px, py));
      EXPECT_EQ(e.max_height(px, py), fresh.max_height(px, py));
      if (differs) {
        ++changed_patches;
        EXPECT_TRUE(touched.count({px, py})) << "patch " << px << "," << py << " changed but was not touched";
      }
    }
  }
  EXPECT_GT(changed_patches, 0);
}

// Leitao & Carmo's tiled blocks, block-based, crack correction by skirts: with every side at
// its patch's own level the mesh has cracks where levels differ (no index update), and each
// patch's skirt reaches below the largest gap along its sides, at every sample of every side,
// for every patch size of their Table 1 at their 8 px budget (and at 2 px).
TEST(TiledBlocks, SkirtsReachBelowEveryCrackBetweenBlocksDrawnAtTheirOwnLevels) {
  const Terrain t = rough(300, 257, 21);
  for (int32_t n : {17, 33, 65}) {
    const GeomipmapGrid g = grid_for(t, n);
    const GeomipmapErrors e = GeomipmapErrors::compute(g, t.grid());
    for (const LodView& v :
         {view_at(100, 100, 500, 8.0), view_at(600, 500, 1200, 8.0), view_at(300, -50, 700, 2.0)}) {
      std::vector<PatchLod> lods = select_lods(g, e, kScale, v);
      assign_own_sides(lods);
      const std::vector<float> depth = skirt_depths(g, e, lods);
      const lod::WatertightReport r = lod::check_watertight(replicate(g, lods), g.covered());
      double widest = 0, slack = 1e30;
      int64_t cracked_sides = 0;
      auto check = [&](int32_t px, int32_t py, int32_t side, int32_t qx, int32_t qy, int32_t qside) {
        const size_t p = size_t(py * g.patches_x + px), q = size_t(qy * g.patches_x + qx);
        const auto a = side_profile(g, t.grid(), px, py, lods[p], side);
        const auto b = side_profile(g, t.grid(), qx, qy, lods[q], qside);
        double gap = 0;
        for (size_t k = 0; k < a.size(); ++k) gap = std::max(gap, double(std::abs(a[k] - b[k])));
        cracked_sides += gap > 0;
        widest = std::max(widest, gap);
        slack = std::min(slack, double(std::min(depth[p], depth[q])) - gap);
        EXPECT_LE(gap, std::min(depth[p], depth[q])) << "patch size " << n << " at " << px << "," << py;
      };
      for (int32_t py = 0; py < g.patches_y; ++py) {
        for (int32_t px = 0; px < g.patches_x; ++px) {
          if (px + 1 < g.patches_x) check(px, py, kSideRight, px + 1, py, kSideLeft);
          if (py + 1 < g.patches_y) check(px, py, kSideBottom, px, py + 1, kSideTop);
        }
      }
      std::printf(
          "patch %d, %.0f px: %lld cracked sides, widest %.0f units, least slack %.0f units, mesh: %s\n", n,
          v.tolerance_px, static_cast<long long>(cracked_sides), widest, slack, r.describe().c_str());
      // Levels or morphs differ somewhere: without the skirts there are cracks (T-junctions where
      // levels differ, height steps where only morphs do).
      EXPECT_GT(cracked_sides, 0);
    }
  }
  // With index updates instead, the two sides of every shared edge are one line.
  const GeomipmapGrid g = grid_for(t, 17);
  const GeomipmapErrors e = GeomipmapErrors::compute(g, t.grid());
  const std::vector<PatchLod> lods = select_lods(g, e, kScale, view_at(100, 100, 500, 8.0));
  for (int32_t py = 0; py < g.patches_y; ++py)
    for (int32_t px = 0; px + 1 < g.patches_x; ++px) {
      const auto a = side_profile(g, t.grid(), px, py, lods[size_t(py * g.patches_x + px)], kSideRight);
      const auto b =
          side_profile(g, t.grid(), px + 1, py, lods[size_t(py * g.patches_x + px + 1)], kSideLeft);
      for (size_t k = 0; k < a.size(); ++k) EXPECT_NEAR(a[k], b[k], 1e-3);
    }
}

}  // namespace
}  // namespace loam::lod
