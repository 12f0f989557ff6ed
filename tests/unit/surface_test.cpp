#include "protocol/surface.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace loam {
namespace {

World random_heights_world(WorldParams p, uint32_t seed, int amplitude = 65535) {
  std::mt19937 rng(seed);
  std::vector<uint16_t> s(size_t(p.sample_rect().area()));
  for (auto& v : s) v = uint16_t(rng() % uint32_t(amplitude));
  return std::move(*World::from_samples(p, s));
}

WorldParams params(double mps, int32_t ox, int32_t oy) {
  WorldParams p;
  p.meters_per_sample = mps;  // 0.1 is not representable in binary: the hard case
  p.meters_per_unit = 0.01;
  p.height_offset = -100;
  p.origin_tile_x = ox;
  p.origin_tile_y = oy;
  p.tiles_x = 2;
  p.tiles_y = 2;
  return p;
}

TEST(Surface, HeightIsExactAtEverySamplePositionEvenForUnrepresentableSpacing) {
  for (const WorldParams p : {params(0.1, 0, 0), params(0.3, -5, 7), params(2.0, 20000, -30000)}) {
    const World w = random_heights_world(p, 11);
    const RectI r = p.sample_rect();
    for (int64_t y = r.y0; y < r.y1; y += 7) {
      for (int64_t x = r.x0; x < r.x1; x += 3) {
        const double mx = double(x) * p.meters_per_sample, my = double(y) * p.meters_per_sample;
        ASSERT_EQ(height_at(w, mx, my), p.height_meters(w.coarse(x, y)))
            << "sample " << x << "," << y << " at spacing " << p.meters_per_sample;
      }
    }
  }
}

TEST(Surface, HeightIsContinuousAcrossTileBordersAndCorners) {
  const WorldParams p = params(1.0, -1, -1);  // tile borders at sample 0 and the four-tile corner (0,0)
  const World w = random_heights_world(p, 12, 2000);
  const double max_slope = 2000 * p.meters_per_unit;  // meters per meter between neighbours
  for (double eps : {1e-3, 1e-6, 1e-9}) {
    for (double along = -3.5; along <= 3.5; along += 0.25) {
      const double dx = height_at(w, -eps, along) - height_at(w, eps, along);
      const double dy = height_at(w, along, -eps) - height_at(w, along, eps);
      const double dc = height_at(w, -eps, -eps) - height_at(w, eps, eps);
      EXPECT_LE(std::fabs(dx), 2 * eps * max_slope + 1e-9);
      EXPECT_LE(std::fabs(dy), 2 * eps * max_slope + 1e-9);
      EXPECT_LE(std::fabs(dc), 4 * eps * max_slope + 1e-9);
    }
  }
}

TEST(Surface, BilinearMidpointIsTheAverageOfItsNeighbours) {
  const WorldParams p = params(1.0, 0, 0);
  const World w = random_heights_world(p, 13);
  const double mid = height_at(w, 255.5, 255.5);
  const double avg = (p.height_meters(w.coarse(255, 255)) + p.height_meters(w.coarse(256, 255)) +
                      p.height_meters(w.coarse(255, 256)) + p.height_meters(w.coarse(256, 256))) /
                     4;
  EXPECT_NEAR(mid, avg, 1e-9);
}

TEST(Surface, NormalOfAnEightyDegreeCliffIsEightyDegrees) {
  // A planar ramp rising 71 units of 1 cm per 12.5 cm sample: slope 5.68, 80.01 degrees.
  // FD4 is exact on polynomials of degree <= 4 and the ramp is exactly representable, so
  // the normal must come out exact; no 45 degree cone limit may clamp it.
  WorldParams p = params(0.125, 0, 0);
  p.height_offset = 0;
  std::vector<uint16_t> s(size_t(p.sample_rect().area()));
  for (int64_t y = 0; y < 512; ++y) {
    for (int64_t x = 0; x < 512; ++x) s[size_t(y * 512 + x)] = uint16_t(71 * x);
  }
  const World w = *World::from_samples(p, s);
  const double expected = std::atan(71 * 0.01 / 0.125) * 180.0 / std::numbers::pi;
  ASSERT_GT(expected, 80.0);
  for (double x : {0.0, 0.1, 10.0, 31.9, 63.875}) {
    const Vec3d n = normal_at(w, x, 20.0);
    const double angle = std::acos(n.z) * 180.0 / std::numbers::pi;
    EXPECT_NEAR(angle, expected, 1e-6) << "at x = " << x << " (edges use one-sided stencils)";
    EXPECT_NEAR(n.y, 0.0, 1e-12);
    EXPECT_LT(n.x, 0.0) << "uphill toward +x tilts the normal toward -x";
  }
}

TEST(Surface, NormalIsContinuousAcrossTileBorders) {
  const WorldParams p = params(1.0, -1, -1);
  const World w = random_heights_world(p, 14, 300);
  for (double along = -5; along <= 5; along += 0.5) {
    const Vec3d a = normal_at(w, -1e-9, along), b = normal_at(w, 1e-9, along);
    EXPECT_NEAR(a.x, b.x, 1e-6);
    EXPECT_NEAR(a.y, b.y, 1e-6);
    EXPECT_NEAR(a.z, b.z, 1e-6);
  }
}

TEST(Surface, Fd4DerivativeIsExactOnQuarticsIncludingOneSidedEdges) {
  auto f = [](int64_t i) {
    const double x = double(i) * 0.5;
    return 3 + 2 * x - x * x + 0.25 * x * x * x - 0.01 * x * x * x * x;
  };
  auto df = [](double x) { return 2 - 2 * x + 0.75 * x * x - 0.04 * x * x * x; };
  for (int64_t i = 0; i < 12; ++i) {
    EXPECT_NEAR(fd4_derivative(f, i, 0, 12, 0.5), df(double(i) * 0.5), 1e-9) << "index " << i;
  }
}

TEST(Surface, QueriesOutsideTheWorldClampToItsEdge) {
  const WorldParams p = params(1.0, 0, 0);
  const World w = random_heights_world(p, 15);
  EXPECT_EQ(height_at(w, -50.0, 3.0), p.height_meters(w.coarse(0, 3)));
  EXPECT_EQ(height_at(w, 10000.0, 511.0), p.height_meters(w.coarse(511, 511)));
}

}  // namespace
}  // namespace loam
