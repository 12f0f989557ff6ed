// The game library's queries (client/query/): height and normal on the triangles the renderer
// draws, rays and sphere/capsule sweeps against them, checked against brute force over every
// triangle, and the snapshots they run on.
#include "client/query/terrain_query.h"

#include <gtest/gtest.h>

#include <cmath>
#include <glm/geometric.hpp>
#include <limits>
#include <numbers>
#include <random>

#include "client/query/collide.h"
#include "client/query/snapshot_builder.h"
#include "protocol/world.h"

namespace loam::query {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

WorldParams params(int32_t tiles_x, int32_t tiles_y, double spacing = 2.0) {
  WorldParams p;
  p.meters_per_sample = spacing;
  p.meters_per_unit = 1.0 / 64.0;
  p.tiles_x = tiles_x;
  p.tiles_y = tiles_y;
  return p;
}

// Rolling hills (170..450 m) with 1.5 m of noise on 2 m samples: every contact case occurs.
World rough_world(const WorldParams& p, uint32_t seed) {
  World w(p);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> noise(-100, 100);
  const RectI r = p.sample_rect();
  std::vector<uint16_t> s(size_t(r.area()));
  for (int64_t y = r.y0; y < r.y1; ++y) {
    for (int64_t x = r.x0; x < r.x1; ++x) {
      const double h = 20000 + 9000 * std::sin(double(x) * 0.031) * std::cos(double(y) * 0.023) + noise(rng);
      s[size_t((y - r.y0) * r.width() + (x - r.x0))] = uint16_t(std::clamp(h, 0.0, 65535.0));
    }
  }
  (void)w.write_coarse(r, s);
  (void)w.commit(1);
  return w;
}

std::vector<TileCoord> all_tiles(const WorldParams& p, bool detail = false) {
  std::vector<TileCoord> out;
  const RectI t = p.tile_range(0);
  for (int64_t ty = t.y0; ty < t.y1; ++ty) {
    for (int64_t tx = t.x0; tx < t.x1; ++tx) out.push_back({Layer::kCoarse, 0, int32_t(tx), int32_t(ty)});
  }
  if (detail) {
    const int32_t f = p.detail_factor;
    for (int64_t ty = t.y0 * f; ty < t.y1 * f; ++ty) {
      for (int64_t tx = t.x0 * f; tx < t.x1 * f; ++tx)
        out.push_back({Layer::kDetail, 0, int32_t(tx), int32_t(ty)});
    }
  }
  return out;
}

std::shared_ptr<const TerrainSnapshot> snapshot_of(const World& w, std::vector<TileCoord> held) {
  SnapshotBuilder b(w.params());
  return b.build(w, held, {}, 1, 0);
}

// Every triangle of the cells overlapping [x0, x1] x [y0, y1] (meters), the renderer's split.
std::vector<Triangle> brute_triangles(const World& w, double x0, double y0, double x1, double y1) {
  const WorldParams& p = w.params();
  const double h = p.meters_per_sample;
  const RectI r = p.sample_rect();
  std::vector<Triangle> out;
  const int64_t i0 = std::max<int64_t>(r.x0, int64_t(std::floor(x0 / h)) - 1);
  const int64_t i1 = std::min<int64_t>(r.x1 - 2, int64_t(std::floor(x1 / h)) + 1);
  const int64_t j0 = std::max<int64_t>(r.y0, int64_t(std::floor(y0 / h)) - 1);
  const int64_t j1 = std::min<int64_t>(r.y1 - 2, int64_t(std::floor(y1 / h)) + 1);
  auto v = [&](int64_t i, int64_t j) {
    return glm::dvec3{double(i) * h, double(j) * h, p.height_meters(w.coarse(i, j))};
  };
  for (int64_t j = j0; j <= j1; ++j) {
    for (int64_t i = i0; i <= i1; ++i) {
      out.push_back({v(i, j), v(i + 1, j), v(i + 1, j + 1)});
      out.push_back({v(i, j), v(i + 1, j + 1), v(i, j + 1)});
    }
  }
  return out;
}

double min_distance(const std::vector<Triangle>& tris, const glm::dvec3& a, const glm::dvec3& b) {
  double best = INFINITY;
  for (const Triangle& t : tris) best = std::min(best, closest_segment_triangle(a, b, t).distance);
  return best;
}

TEST(Collide, SphereMeetsAFaceAnEdgeAndAVertexWhereGeometrySays) {
  const Triangle tri{{0, 0, 0}, {10, 0, 0}, {0, 10, 0}};
  // Face: falls straight down from 5 m, radius 1: touches after 4 of 10 m.
  auto face = sweep_capsule_triangle({{2, 2, 5}, {2, 2, 5}, 1.0}, {0, 0, -10}, tri);
  ASSERT_TRUE(face);
  EXPECT_NEAR(face->t, 0.4, 1e-7);
  EXPECT_NEAR(face->normal.z, 1.0, 1e-9);
  // Edge: moving along -y toward the edge y = 0 at height 0.5: touches when the centre is
  // sqrt(1 - 0.25) beyond the edge.
  auto edge = sweep_capsule_triangle({{5, -5, 0.5}, {5, -5, 0.5}, 1.0}, {0, 10, 0}, tri);
  ASSERT_TRUE(edge);
  EXPECT_NEAR(-5 + 10 * edge->t, -std::sqrt(0.75), 1e-6);
  EXPECT_NEAR(edge->point.y, 0.0, 1e-9);
  // Vertex: moving along -x toward vertex (0, 0, 0) from behind it.
  auto vertex = sweep_capsule_triangle({{-5, -0.6, 0}, {-5, -0.6, 0}, 1.0}, {10, 0, 0}, tri);
  ASSERT_TRUE(vertex);
  EXPECT_NEAR(-5 + 10 * vertex->t, -0.8, 1e-6);
  EXPECT_NEAR(glm::length(vertex->point), 0.0, 1e-9);
  // Moving away, or passing by: nothing.
  EXPECT_FALSE(sweep_capsule_triangle({{2, 2, 5}, {2, 2, 5}, 1.0}, {0, 0, 10}, tri));
  EXPECT_FALSE(sweep_capsule_triangle({{20, 20, 0.5}, {20, 20, 0.5}, 1.0}, {0, 10, 0}, tri));
}

TEST(Collide, CapsuleMeetsAnEdgeWithItsSideAndStartsInsideWhenOverlapping) {
  const Triangle tri{{0, 0, 0}, {10, 0, 0}, {0, 10, 0}};
  // A horizontal capsule along y, crossing the edge x = 0 from the side, at height 0: its side
  // (not an end) meets the edge when the axis is one radius away.
  auto side = sweep_capsule_triangle({{-5, 2, 0}, {-5, 8, 0}, 0.5}, {10, 0, 0}, tri);
  ASSERT_TRUE(side);
  EXPECT_NEAR(-5 + 10 * side->t, -0.5, 1e-6);
  auto inside = sweep_capsule_triangle({{1, 1, 0.2}, {1, 1, 2}, 0.5}, {0, 0, 1}, tri);
  ASSERT_TRUE(inside);
  EXPECT_TRUE(inside->started_inside);
  EXPECT_EQ(inside->t, 0.0);
}

TEST(TerrainQuery, HeightAtEverySampleIsThatSampleExactly) {
  const World w = rough_world(params(2, 2, 1.5), 7);
  const auto s = snapshot_of(w, all_tiles(w.params()));
  const RectI r = w.params().sample_rect();
  for (int64_t y = r.y0; y < r.y1; y += 7) {
    for (int64_t x = r.x0; x < r.x1; x += 5) {
      const auto h = height_at(*s, double(x) * 1.5, double(y) * 1.5);
      ASSERT_TRUE(h) << x << "," << y;
      ASSERT_EQ(*h, w.params().height_meters(w.coarse(x, y))) << x << "," << y;
    }
  }
  // The last row and column (the world's far edge) too.
  EXPECT_EQ(*height_at(*s, double(r.x1 - 1) * 1.5, double(r.y1 - 1) * 1.5),
            w.params().height_meters(w.coarse(r.x1 - 1, r.y1 - 1)));
}

TEST(TerrainQuery, BetweenSamplesTheHeightIsTheDrawnTrianglesPlaneAndTheNormalItsGradient) {
  const World w = rough_world(params(2, 1), 3);
  const auto s = snapshot_of(w, all_tiles(w.params()));
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> ux(0.0, 510.0 * 2.0), uy(0.0, 254.0 * 2.0);
  for (int k = 0; k < 2000; ++k) {
    const double x = ux(rng), y = uy(rng);
    const auto tris = brute_triangles(w, x, y, x, y);
    // The triangle under (x, y): a vertical ray from above meets it.
    std::optional<double> z;
    glm::dvec3 n{0.0};
    for (const Triangle& t : tris) {
      if (auto hit = ray_triangle({x, y, 2000.0}, {0, 0, -1}, t, 1e9)) {
        z = 2000.0 - *hit;
        n = upward_normal(t);
        break;
      }
    }
    ASSERT_TRUE(z);
    const auto h = height_at(*s, x, y);
    ASSERT_TRUE(h);
    ASSERT_NEAR(*h, *z, 1e-9) << x << "," << y;
    const auto qn = normal_at(*s, x, y);
    ASSERT_TRUE(qn);
    ASSERT_NEAR(glm::length(*qn - n), 0.0, 1e-9) << x << "," << y;
  }
}

TEST(TerrainQuery, TilesNotHeldAnswerNothingAndRaysReportCrossingThem) {
  const World w = rough_world(params(2, 2), 5);
  const auto s = snapshot_of(w, {{Layer::kCoarse, 0, 0, 0}});
  EXPECT_TRUE(height_at(*s, 100, 100));
  EXPECT_FALSE(height_at(*s, 600, 600));           // tile (1, 1)
  EXPECT_FALSE(height_at(*s, 255.0 * 2 + 1, 20));  // a cell reaching into tile (1, 0)
  EXPECT_FALSE(height_at(*s, -5, 20));             // outside the world
  EXPECT_FALSE(height_at(*s, kNaN, 20));
  EXPECT_FALSE(normal_at(*s, 20, kNaN));
  const RayResult far = raycast(*s, {100, 100, 5000}, {1, 1, 0}, 2000);
  EXPECT_FALSE(far.hit);
  EXPECT_TRUE(far.reached_unheld);
  const SweepResult sweep = sweep_sphere(*s, {600, 600, 2000}, 1.0, {0, 0, -3000});
  EXPECT_FALSE(sweep.contact);
  EXPECT_TRUE(sweep.reached_unheld);
}

TEST(TerrainQuery, BadRaysAndShapesFindNothing) {
  const World w = rough_world(params(1, 1), 5);
  const auto s = snapshot_of(w, all_tiles(w.params()));
  EXPECT_FALSE(raycast(*s, {10, 10, 9000}, {0, 0, 0}, 1e4).hit);
  EXPECT_FALSE(raycast(*s, {10, kNaN, 9000}, {0, 0, -1}, 1e4).hit);
  EXPECT_FALSE(raycast(*s, {10, 10, 9000}, {0, 0, -1}, kNaN).hit);
  EXPECT_FALSE(sweep_sphere(*s, {10, 10, 900}, kNaN, {0, 0, -2000}).contact);
  EXPECT_FALSE(sweep_sphere(*s, {10, 10, 900}, -1.0, {0, 0, -2000}).contact);
  EXPECT_FALSE(sweep_sphere(*s, {10, 10, 900}, 1.0, {0, 0, INFINITY}).contact);
}

TEST(TerrainQuery, VerticalRaysHitTheHeightQueryExactly) {
  const World w = rough_world(params(2, 2), 9);
  const auto s = snapshot_of(w, all_tiles(w.params()));
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0.0, 1020.0);
  for (int k = 0; k < 500; ++k) {
    // Half of them exactly at samples (where a ray meets the shared vertex of six triangles).
    double x = u(rng), y = u(rng);
    if (k % 2) x = std::round(x / 2) * 2, y = std::round(y / 2) * 2;
    const RayResult r = raycast(*s, {x, y, 3000}, {0, 0, -1}, 1e4);
    ASSERT_TRUE(r.hit) << x << "," << y;
    EXPECT_NEAR(r.hit->point.z, *height_at(*s, x, y), 1e-9);
    EXPECT_FALSE(r.reached_unheld);
  }
}

TEST(TerrainQuery, RaysFindTheNearestTriangleOfBruteForceAndSkipBlocksAboveTheTerrain) {
  const World w = rough_world(params(2, 2), 21);
  const auto s = snapshot_of(w, all_tiles(w.params()));
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> u(0.0, 1020.0), dz(-0.6, 0.1), ang(0.0, 2 * std::numbers::pi);
  QueryWork work;
  int hits = 0;
  for (int k = 0; k < 150; ++k) {
    const glm::dvec3 o{u(rng), u(rng), 250.0 + 400.0 * std::abs(dz(rng))};
    const double a = ang(rng);
    const glm::dvec3 d = glm::normalize(glm::dvec3{std::cos(a), std::sin(a), dz(rng)});
    const double len = 300.0;
    const glm::dvec3 e = o + d * len;
    double best = INFINITY;
    for (const Triangle& t :
         brute_triangles(w, std::min(o.x, e.x), std::min(o.y, e.y), std::max(o.x, e.x), std::max(o.y, e.y))) {
      if (auto hit = ray_triangle(o, d, t, len)) best = std::min(best, *hit);
    }
    // Leaving the world ends the ray: brute force counts only what lies inside it.
    const RayResult r = raycast(*s, o, d, len, &work);
    if (std::isinf(best)) {
      EXPECT_FALSE(r.hit) << k;
    } else {
      ASSERT_TRUE(r.hit) << k;
      EXPECT_NEAR(r.hit->distance, best, 1e-7) << k;
      ++hits;
    }
  }
  EXPECT_GT(hits, 40);
  EXPECT_GT(work.blocks_skipped, 0u);
}

TEST(TerrainQuery, SphereAndCapsuleSweepsStopWhereTheyFirstTouchAndNotBefore) {
  const World w = rough_world(params(1, 1), 13);
  const auto s = snapshot_of(w, all_tiles(w.params()));
  std::mt19937 rng(2);
  // Sideways by up to 5 m on the way down (the hills change little over that), tilted capsules.
  std::uniform_real_distribution<double> u(40.0, 470.0), m(-5.0, 5.0), r(0.2, 3.0), up(2.0, 40.0);
  int contacts = 0;
  for (int k = 0; k < 60; ++k) {
    const double x = u(rng), y = u(rng);
    const double radius = r(rng);
    // Above every height of the world, falling to 5 m below the ground under its start.
    const glm::dvec3 a{x, y, 480.0 + radius + up(rng)};
    const glm::dvec3 b = k % 2 ? a : a + glm::dvec3{m(rng) * 0.3, m(rng) * 0.3, 1.5};
    const glm::dvec3 motion{m(rng), m(rng), *height_at(*s, x, y) - 5.0 - a.z};
    const SweepResult res = sweep_capsule(*s, {a, b, radius}, motion);
    ASSERT_FALSE(res.reached_unheld);
    if (!res.contact) {
      // Where the ground under its end lies lower still it may miss: then it never came close.
      const glm::dvec3 e = a + motion;
      const auto all = brute_triangles(w, std::min(a.x, e.x) - radius - 3, std::min(a.y, e.y) - radius - 3,
                                       std::max(a.x, e.x) + radius + 3, std::max(a.y, e.y) + radius + 3);
      for (int i = 0; i <= 64; ++i) {
        EXPECT_GT(min_distance(all, a + motion * (i / 64.0), b + motion * (i / 64.0)), radius - 1e-6) << k;
      }
      continue;
    }
    ++contacts;
    const double t = res.contact->t;
    EXPECT_FALSE(res.contact->started_inside);
    const glm::dvec3 at = a + motion * t;
    const auto tris =
        brute_triangles(w, at.x - radius - 3, at.y - radius - 3, at.x + radius + 3, at.y + radius + 3);
    const auto all = brute_triangles(w, std::min(a.x, at.x) - radius - 3, std::min(a.y, at.y) - radius - 3,
                                     std::max(a.x, at.x) + radius + 3, std::max(a.y, at.y) + radius + 3);
    // At the contact the shape is one radius from the terrain...
    EXPECT_NEAR(min_distance(tris, at, b + motion * t), radius, 1e-5) << k;
    // ... and before it, never closer.
    for (int i = 0; i < 64; ++i) {
      const double f = t * i / 64;
      ASSERT_GT(min_distance(all, a + motion * f, b + motion * f), radius - 1e-5) << k << " at " << f;
    }
    EXPECT_GT(res.contact->normal.z, 0.0);
  }
  EXPECT_GT(contacts, 50);
}

TEST(TerrainQuery, ASphereDroppedOnFlatGroundRestsOneRadiusAboveIt) {
  World w(params(1, 1), 6400);  // 100 m everywhere
  const auto s = snapshot_of(w, all_tiles(w.params()));
  const SweepResult r = sweep_sphere(*s, {101.3, 77.7, 150}, 0.75, {0, 0, -100});
  ASSERT_TRUE(r.contact);
  EXPECT_NEAR(150 - 100 * r.contact->t, 100.75, 1e-9);
  EXPECT_NEAR(r.contact->normal.z, 1.0, 1e-12);
}

TEST(TerrainQuery, DetailOffsetsAddToTheSurfaceOnTheirFinerGrid) {
  WorldParams p = params(1, 1);
  World w(p, 6400);
  // One detail tile with a ramp of offsets.
  std::vector<int8_t> d(kTileSamples);
  for (int y = 0; y < kTileSize; ++y) {
    for (int x = 0; x < kTileSize; ++x) d[size_t(y * kTileSize + x)] = int8_t((x + y) % 100 - 50);
  }
  (void)w.write_detail(tile_rect(0, 0), d);
  (void)w.commit(1);
  const auto s = snapshot_of(w, all_tiles(p, true));
  ASSERT_EQ(s->detail_tiles(), 1u);
  const double dm = p.detail_meters_per_sample();
  for (int k = 0; k < 200; k += 7) {
    const int dx = k, dy = (k * 3) % 250;
    EXPECT_EQ(*height_at(*s, dx * dm, dy * dm), 100.0 + p.detail_meters(d[size_t(dy * kTileSize + dx)]));
    const RayResult r = raycast(*s, {dx * dm, dy * dm, 200}, {0, 0, -1}, 1000);
    ASSERT_TRUE(r.hit);
    EXPECT_NEAR(r.hit->point.z, *height_at(*s, dx * dm, dy * dm), 1e-9);
  }
  // Beyond the detail tile (coarse cell 64 and on) the plain coarse surface.
  EXPECT_EQ(*height_at(*s, 300.5, 20.25), 100.0);
}

TEST(SnapshotBuilder, SharesUntouchedTilesCopiesChangedOnesAndOldSnapshotsStayAsTheyWere) {
  World w = rough_world(params(2, 2), 17);
  SnapshotBuilder b(w.params());
  const auto held = all_tiles(w.params());
  const auto first = b.build(w, held, {}, 1, 0);
  EXPECT_EQ(b.tiles_copied(), 4u);
  const double before = *height_at(*first, 20, 20);
  // Change a rect inside tile (0, 0).
  std::vector<uint16_t> flat(size_t(10 * 10), 0);
  (void)w.write_coarse({5, 5, 15, 15}, flat);
  (void)w.commit(2);
  const auto second = b.build(w, held, std::vector<ChangedRect>{{Layer::kCoarse, {5, 5, 15, 15}}}, 2, 0);
  EXPECT_EQ(b.tiles_copied(), 5u);
  EXPECT_EQ(*height_at(*second, 20, 20), w.params().height_meters(0));
  EXPECT_EQ(*height_at(*first, 20, 20), before);  // the old one is unchanged
  EXPECT_NE(first->coarse_tile(0, 0), second->coarse_tile(0, 0));
  EXPECT_EQ(first->coarse_tile(1, 1), second->coarse_tile(1, 1));  // shared
  EXPECT_EQ(second->stamp().generation, 2u);
  EXPECT_EQ(second->stamp().event_seq, 2u);
  // A tile no longer held is gone from the next snapshot.
  const auto third = b.build(w, std::vector<TileCoord>(held.begin(), held.begin() + 3), {}, 2, 0);
  EXPECT_EQ(third->coarse_tiles(), 3u);
  EXPECT_EQ(b.tiles_copied(), 5u);
}

}  // namespace
}  // namespace loam::query
