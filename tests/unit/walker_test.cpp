// The walk mode's character (client/controls/walker.h) on snapshots of small worlds: it stands on
// slopes it may climb, slides down steeper ones, jumps as high as physics says, follows the
// ground while walking, and falls into a crater dug under it in the time a fall takes.
#include "client/controls/walker.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "client/query/snapshot_builder.h"
#include "client/query/terrain_query.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/world.h"
#include "stamps_test_util.h"

namespace loam::controls {
namespace {

WorldParams params() {
  WorldParams p;
  p.meters_per_sample = 1.0;
  p.meters_per_unit = 1.0 / 64.0;
  p.tiles_x = p.tiles_y = 1;
  return p;
}

// A world whose height at sample (x, y) is height(x, y) metres.
template <class Height>
World world_of(const Height& height, const WorldParams& p = params()) {
  World w(p);
  const RectI r = p.sample_rect();
  std::vector<uint16_t> s(size_t(r.area()));
  for (int64_t y = 0; y < r.y1; ++y) {
    for (int64_t x = 0; x < r.x1; ++x)
      s[size_t(y * r.x1 + x)] = quantize_height(p, height(double(x), double(y)));
  }
  (void)w.write_coarse(r, s);
  (void)w.commit(1);
  return w;
}

double rise_of(double degrees) { return std::tan(degrees * std::numbers::pi / 180.0); }

// A plane rising along +x at `degrees`, from 50 m at x = 0.
World slope_world(double degrees) {
  return world_of([rise = rise_of(degrees)](double x, double) { return 50.0 + rise * x; });
}

std::shared_ptr<const query::TerrainSnapshot> snap(const World& w) {
  query::SnapshotBuilder b(w.params());
  const std::vector<TileCoord> held = {{Layer::kCoarse, 0, 0, 0}};
  return b.build(w, held, {}, 1, 0);
}

double ground(const query::TerrainSnapshot& s, const Walker& w) {
  return *query::height_at(s, w.feet.x, w.feet.y);
}

TEST(Walker, PlacedOnAWalkableSlopeItStaysOnTheGroundStandingAndWalking) {
  const World world = slope_world(30);
  const auto s = snap(world);
  Walker w = place_walker(*s, 100, 128);
  ASSERT_TRUE(w.grounded);
  const double z0 = w.feet.z;
  for (int i = 0; i < 300; ++i) step_walker(w, *s, {}, 1.0 / 60);  // 5 s standing
  EXPECT_TRUE(w.grounded);
  EXPECT_NEAR(w.feet.z, z0, 0.01);
  EXPECT_NEAR(w.feet.x, 100, 0.01);
  // Uphill, then downhill: on the ground all the way (never more than a few cm above it).
  for (double yaw : {0.0, std::numbers::pi}) {
    for (int i = 0; i < 240; ++i) {
      step_walker(w, *s, {1.0, 0.0, yaw}, 1.0 / 60);
      ASSERT_TRUE(w.grounded) << "yaw " << yaw << " step " << i;
      // The capsule's lowest point rests on the slope a little above the ground under its axis.
      ASSERT_LT(w.feet.z - ground(*s, w), 0.3 * (1.0 / std::cos(std::numbers::pi / 6) - 1.0) + 0.05);
      ASSERT_GE(w.feet.z - ground(*s, w), -1e-6);
    }
  }
  EXPECT_NEAR(w.feet.x, 100, 0.05);  // 4 s up at 1.4 m/s along the slope, 4 s back
}

TEST(Walker, SteeperThanItsLimitItSlidesDown) {
  const World world = slope_world(60);
  const auto s = snap(world);
  Walker w = place_walker(*s, 120, 128);
  EXPECT_FALSE(w.grounded);
  const double x0 = w.feet.x;
  for (int i = 0; i < 60; ++i) step_walker(w, *s, {}, 1.0 / 60);
  EXPECT_LT(w.feet.x, x0 - 1.0);
  EXPECT_GE(w.feet.z - ground(*s, w), -1e-6);  // sliding on it, not through it
}

// A V valley along y whose two faces rise at `degrees` from x = 128.
World valley_world(double degrees) {
  return world_of([rise = rise_of(degrees)](double x, double) { return 50.0 + rise * std::abs(x - 128.0); });
}

// Each face of the valley is too steep to stand on, but together they hold it: it slides into
// the crease and stands there, frame after frame (a faceted crater floor is such a crease).
TEST(Walker, InACreaseOfTwoSteepFacesItStandsWhereTheyMeet) {
  const World world = valley_world(50);
  const auto s = snap(world);
  Walker w = place_walker(*s, 129.5, 128);
  EXPECT_FALSE(w.grounded);
  for (int i = 0; i < 120; ++i) step_walker(w, *s, {}, 1.0 / 60);
  EXPECT_NEAR(w.feet.x, 128.0, 0.05);
  for (int i = 0; i < 240; ++i) {
    step_walker(w, *s, {}, 1.0 / 60);
    ASSERT_TRUE(w.grounded) << "frame " << i << ", feet at " << w.feet.x << ", " << w.feet.z;
  }
  EXPECT_NEAR(w.feet.x, 128.0, 0.05);
  EXPECT_GE(w.feet.z - ground(*s, w), -1e-6);
  // One face as steep alone never holds it: it slides.
  const World slope = slope_world(50);
  const auto t = snap(slope);
  Walker alone = place_walker(*t, 120, 128);
  for (int i = 0; i < 120; ++i) {
    step_walker(alone, *t, {}, 1.0 / 60);
    EXPECT_FALSE(alone.grounded);
  }
}

// What the viewer's walker met at a crater's foot under load: a crease of two 53-degree faces
// whose floor itself falls at 53 degrees before it levels out. Neither the faces nor the crease
// hold it there; it slides down along the crease, as a ball would, and stands where the floor
// levels (it stayed wedged in the air, motion and velocity spent bouncing between the faces).
TEST(Walker, InASteepCreaseItSlidesDownAlongItAndStandsWhereItLevels) {
  const World world = world_of([](double x, double y) {
    const double floor = x < 128.0 ? 100.0 - 1.3 * (x - 128.0) : 100.0 - 0.2 * (x - 128.0);
    return floor + 1.3 * std::abs(y - 128.0);
  });
  const auto s = snap(world);
  Walker w = place_walker(*s, 120.0, 128.1);
  EXPECT_FALSE(w.grounded);
  int frames = 0;
  while (!w.grounded && frames < 600) {
    step_walker(w, *s, {}, 1.0 / 60);
    ++frames;
  }
  ASSERT_TRUE(w.grounded) << "feet at " << w.feet.x << ", " << w.feet.y << ", " << w.feet.z;
  EXPECT_GT(w.feet.x, 127.0) << "it slid down the crease to where the floor levels";
  EXPECT_NEAR(w.feet.y, 128.0, 0.1);
  EXPECT_GE(w.feet.z - ground(*s, w), -1e-6);
  for (int i = 0; i < 120; ++i) {
    step_walker(w, *s, {}, 1.0 / 60);
    ASSERT_TRUE(w.grounded) << "frame " << i;
  }
}

// A pit of three faces at 75 degrees, 120 degrees apart: no two of them make a floor, every
// crease between two runs into the third. Wedged there it rests on them and stands, frame after
// frame, instead of hanging in the air with its fall spent against the faces.
TEST(Walker, WedgedInAPitOfSteepFacesItRestsOnThem) {
  const double k = rise_of(75);
  const World world = world_of([k](double x, double y) {
    double m = -1e9;
    for (int i = 0; i < 3; ++i) {
      const double a = 2.0 * std::numbers::pi * i / 3.0 + 0.3;
      m = std::max(m, std::cos(a) * (x - 128.0) + std::sin(a) * (y - 128.0));
    }
    return 100.0 + k * m;
  });
  const auto s = snap(world);
  for (const double dx : {0.0, 0.12, -0.2}) {
    Walker w;
    w.feet = {128.0 + dx, 128.0 + 0.07, 104.0};
    for (int i = 0; i < 180; ++i) step_walker(w, *s, {}, 1.0 / 60);
    for (int i = 0; i < 60; ++i) {
      step_walker(w, *s, {}, 1.0 / 60);
      ASSERT_TRUE(w.grounded) << "dx " << dx << ", frame " << i << ", feet at " << w.feet.x << ", "
                              << w.feet.y << ", " << w.feet.z;
    }
    EXPECT_NEAR(w.feet.x, 128.0, 0.4);
    EXPECT_NEAR(w.feet.y, 128.0, 0.4);
    EXPECT_GE(w.feet.z - ground(*s, w), -1e-6);
  }
}

TEST(Walker, AJumpRisesAsHighAsItsTakeOffSpeedAllows) {
  World world(params(), 3200);
  const auto s = snap(world);
  Walker w = place_walker(*s, 128, 128);
  ASSERT_TRUE(w.grounded);
  const double z0 = w.feet.z;
  WalkerInput jump;
  jump.jump = true;
  step_walker(w, *s, jump, 1.0 / 60);
  double apex = w.feet.z;
  int frames = 1;
  while (!w.grounded && frames < 600) {
    step_walker(w, *s, {}, 1.0 / 60);
    apex = std::max(apex, w.feet.z);
    ++frames;
  }
  const WalkerConfig c;
  EXPECT_NEAR(apex - z0, c.jump_speed * c.jump_speed / (2 * c.gravity), 0.03);
  EXPECT_NEAR(frames / 60.0, 2 * c.jump_speed / c.gravity, 2.0 / 60);
  EXPECT_NEAR(w.feet.z, z0, 0.01);
}

TEST(Walker, ACraterDugUnderItMakesItFallToTheFloorInTheTimeTheFallTakes) {
  World world(params(), 6400);  // flat, 100 m
  auto s = snap(world);
  Walker w = place_walker(*s, 128, 128);
  ASSERT_TRUE(w.grounded);
  for (int i = 0; i < 30; ++i) step_walker(w, *s, {}, 1.0 / 60);
  const double z0 = w.feet.z;
  // A crater 4 m deep and 20 m wide right under it, as the server would apply it.
  StampParams crater;
  crater.kind = StampKind::kCrater;
  crater.center_x = 128;
  crater.center_y = 128;
  crater.radius = 10;
  crater.intensity = 4;
  const auto q = validate_stamp(crater, world.params());
  ASSERT_TRUE(q) << q.error().describe();
  ASSERT_TRUE(apply_stamp(world, *q));
  (void)world.commit(2);
  s = snap(world);
  const double floor = *query::height_at(*s, w.feet.x, w.feet.y);
  ASSERT_LT(floor, z0 - 3.0);
  int frames = 0;
  while (frames < 600) {
    step_walker(w, *s, {}, 1.0 / 60);
    ++frames;
    if (w.grounded) break;
  }
  ASSERT_TRUE(w.grounded);
  const WalkerConfig c;
  // Free fall from z0 to the floor (the capsule's bottom meets the bowl where it is a little
  // higher than its centre): sqrt(2 d / g), within two frames.
  const double expected = std::sqrt(2.0 * (z0 - w.feet.z) / c.gravity);
  EXPECT_NEAR(frames / 60.0, expected, 2.0 / 60);
  EXPECT_NEAR(w.feet.z, floor, 0.1);
  EXPECT_GE(w.feet.z - floor, -1e-6);
  // And it stays on the floor.
  for (int i = 0; i < 120; ++i) step_walker(w, *s, {}, 1.0 / 60);
  EXPECT_TRUE(w.grounded);
  EXPECT_NEAR(w.feet.x, 128, 0.05);
}

TEST(Walker, BadTimeStepsChangeNothing) {
  World world(params(), 3200);
  const auto s = snap(world);
  Walker w = place_walker(*s, 128, 128);
  const Walker before = w;
  step_walker(w, *s, {1, 0, 0}, std::nan(""));
  step_walker(w, *s, {1, 0, 0}, -1.0);
  step_walker(w, *s, {1, 0, 0}, 0.0);
  EXPECT_EQ(w.feet, before.feet);
}

// As the viewer's walk mode digs: on ground of any slope and roughness, at 1 and 2 m a sample,
// among earlier craters and mounds, a crater dug under the walker's feet takes it to its floor,
// where it stands every frame, whatever the frame times.
TEST(Walker, ACraterDugUnderItOnRoughGroundHoldsItStandingEveryFrame) {
  for (uint32_t seed = 1; seed <= 40; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0, 1);
    WorldParams wp = params();
    wp.meters_per_sample = seed % 2 ? 2.0 : 1.0;
    wp.meters_per_unit = 0.02;
    wp.height_offset = -200;
    const double slope = rise_of(double(seed % 5) * 8.0), rough = double(seed % 3) * 0.5;
    World world = world_of(
        [&](double x, double y) {
          return 100.0 + slope * x * wp.meters_per_sample + rough * std::sin(x * 7 + y * 3);
        },
        wp);
    auto stamp = [&](StampKind k, double x, double y, double r, double in, double shape) {
      StampParams p = stamps_test::make_params(k, x, y, r, in);
      p.shape = shape;
      const auto q = validate_stamp(p, world.params());
      if (q) (void)apply_stamp(world, *q);
    };
    const double M = 128 * wp.meters_per_sample;
    const int prior = int(u(rng) * 6);
    for (int i = 0; i < prior; ++i) {
      const double r = 3 + u(rng) * 20;
      const bool raise = u(rng) < 0.33;
      stamp(raise ? StampKind::kGaussian : StampKind::kCrater, M + (u(rng) - 0.5) * 30,
            M + (u(rng) - 0.5) * 30, r, raise ? 0.2 * r : 0.25 * r, raise ? 0.0 : 0.3);
    }
    (void)world.commit(2);
    auto s = snap(world);
    const double cx = M + (u(rng) - 0.5) * 4, cy = M + (u(rng) - 0.5) * 4;
    Walker w = place_walker(*s, cx, cy);
    for (int i = 0; i < 120; ++i) step_walker(w, *s, {}, 1.0 / 60);
    const double before = w.feet.z;
    stamp(StampKind::kCrater, w.feet.x, w.feet.y, 12, 3, 0.3);
    (void)world.commit(3);
    s = snap(world);
    auto frame = [&] {
      const double elapsed = 0.005 + u(rng) * 0.3;
      for (double left = elapsed; left > 1e-9; left -= 1.0 / 60.0)
        step_walker(w, *s, {}, std::min(left, 1.0 / 60.0));
    };
    for (int i = 0; i < 60; ++i) frame();
    int air = 0;
    for (int i = 0; i < 120; ++i) {
      frame();
      air += !w.grounded;
    }
    EXPECT_EQ(air, 0) << "seed " << seed << ": in the air " << air << " of 120 frames, feet at " << w.feet.x
                      << ", " << w.feet.y << ", " << w.feet.z << " m, ground " << ground(*s, w) << " m";
    EXPECT_LT(w.feet.z, before - 1.0) << "seed " << seed << ": it fell into the crater";
    EXPECT_GE(w.feet.z - ground(*s, w), -1e-6) << "seed " << seed;
  }
}

}  // namespace
}  // namespace loam::controls
