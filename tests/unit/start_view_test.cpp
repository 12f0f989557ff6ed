// Where a viewer starts on a world (client/scene/start_view.h). Pins the bug where the
// windowed viewer on the main job's 131 km world stood 59 km south of the centre, 33 km up
// and outside the world, and drew only sky: every world, from a one-tile DEM to the refined
// world and a 90 m DEM, starts on terrain near its centre, with the sight line clear of the
// relief and controls scaled to the world.
#include "client/scene/start_view.h"

#include <gtest/gtest.h>

#include <cmath>

#include "client/controls/stamp_tool.h"

namespace loam::scene {
namespace {

WorldParams world(double mps, int32_t tiles_x, int32_t tiles_y, int32_t origin_x = 0, int32_t origin_y = 0) {
  return {.meters_per_sample = mps,
          .origin_tile_x = origin_x,
          .origin_tile_y = origin_y,
          .tiles_x = tiles_x,
          .tiles_y = tiles_y};
}

bool inside(const WorldParams& p, double x, double y) {
  const RectI r = p.sample_rect();
  const double m = p.meters_per_sample;
  return x >= double(r.x0) * m && x <= double(r.x1) * m && y >= double(r.y0) * m && y <= double(r.y1) * m;
}

// The sight line from the eye to the focus's ground passes above `ground` by `margin`, up to
// 90% of the way.
double lowest_clearance(const Camera& c, const ViewScale& s, const GroundFn& ground) {
  const double tz = ground(s.focus_x, s.focus_y);
  double lowest = 1e300;
  for (int i = 0; i <= 90; ++i) {
    const double f = i / 100.0;
    const double x = c.x + f * (s.focus_x - c.x), y = c.y + f * (s.focus_y - c.y);
    lowest = std::min(lowest, c.z + f * (tz - c.z) - ground(x, y));
  }
  return lowest;
}

TEST(StartView, OnTheRefinedWorldTheEyeOrbitsTheCentreInsideTheWorldNotFromOutside) {
  const WorldParams p = world(1.0, 512, 384);  // 131 x 98 km at 1 m
  const ViewScale s = view_scale(p);
  EXPECT_DOUBLE_EQ(s.focus_x, 65536.0);
  EXPECT_DOUBLE_EQ(s.focus_y, 49152.0);
  EXPECT_DOUBLE_EQ(s.radius_m, 1500.0);
  const GroundFn flat = [](double, double) { return 120.0; };
  const Camera c = orbit_view(s, 0.0, flat);
  EXPECT_TRUE(inside(p, c.x, c.y));
  EXPECT_NEAR(std::hypot(c.x - s.focus_x, c.y - s.focus_y), 1500.0, 1e-6);
  EXPECT_NEAR(c.z, 120.0 + 300.0, 1e-6) << "flat ground: the base height, nothing to clear";
  // Looking down at the focus, which lies well inside the far plane.
  EXPECT_LT(c.fz, 0.0);
  EXPECT_GE(c.far_m, 2.0 * std::hypot(1500.0, 300.0));
  EXPECT_DOUBLE_EQ(s.view_distance_m, 4000.0);
  // Controls: the radius crossed in 10 s, a crater that shows from 1.5 km.
  EXPECT_DOUBLE_EQ(s.fly_speed_mps, 150.0);
  EXPECT_DOUBLE_EQ(s.tool_radius_m, 37.5);
  EXPECT_DOUBLE_EQ(s.tool_min_radius_m, 0.5);
  EXPECT_DOUBLE_EQ(s.tool_max_radius_m, 500.0);
}

TEST(StartView, OnASmallWorldTheOrbitIsThirtyPercentOfItsShorterSide) {
  const WorldParams p = world(2.0, 4, 3);  // 2048 x 1536 m
  const ViewScale s = view_scale(p);
  EXPECT_DOUBLE_EQ(s.radius_m, 0.3 * 1536.0);
  const Camera c = orbit_view(s, 1.0, [](double, double) { return 0.0; });
  EXPECT_TRUE(inside(p, c.x, c.y));
  const WorldParams one = world(1.0, 1, 1);  // a single tile
  const ViewScale t = view_scale(one);
  EXPECT_DOUBLE_EQ(t.radius_m, 0.3 * 256.0);
  EXPECT_TRUE(inside(one, orbit_view(t, 2.0, {}).x, orbit_view(t, 2.0, {}).y));
  EXPECT_GE(t.tool_radius_m, t.tool_min_radius_m);
}

TEST(StartView, OnACoarseDemTheOrbitSpansAtLeast64SamplesAndToolsScaleWithTheSpacing) {
  const WorldParams p = world(90.0, 3, 3);  // 69 km at 90 m: 1.5 km would be 17 samples
  const ViewScale s = view_scale(p);
  EXPECT_DOUBLE_EQ(s.radius_m, 64.0 * 90.0);
  EXPECT_DOUBLE_EQ(s.tool_min_radius_m, 45.0);
  EXPECT_DOUBLE_EQ(s.tool_max_radius_m, 45000.0);
  EXPECT_GE(s.tool_radius_m, s.tool_min_radius_m);
  EXPECT_DOUBLE_EQ(s.fly_speed_mps, 576.0);
  EXPECT_DOUBLE_EQ(s.view_distance_m, 2.5 * 5760.0) << "the clipmap reaches past the orbit's far side";
}

TEST(StartView, AWorldFarFromTheOriginIsCentredOnItsOwnTiles) {
  const WorldParams p = world(1.0, 8, 8, -100, 40);
  const ViewScale s = view_scale(p);
  EXPECT_DOUBLE_EQ(s.focus_x, (-100.0 + 4.0) * 256.0);
  EXPECT_DOUBLE_EQ(s.focus_y, (40.0 + 4.0) * 256.0);
  const Camera c = orbit_view(s, 3.0, [](double, double) { return -4000.0; });
  EXPECT_TRUE(inside(p, c.x, c.y));
  EXPECT_NEAR(c.z, -4000.0 + s.height_m, 1e-6);
}

TEST(StartView, TheSightLineClearsARidgeBetweenTheEyeAndTheFocus) {
  const ViewScale s = view_scale(world(1.0, 512, 384));
  // An 800 m ridge running north-south halfway between the eye (east) and the focus.
  const GroundFn ridge = [&](double x, double) {
    const double d = (x - (s.focus_x + 750.0)) / 100.0;
    return 100.0 + 800.0 * std::exp(-d * d);
  };
  const Camera c = orbit_view(s, 0.0, ridge);
  EXPECT_GT(c.z, 900.0) << "the eye stands above the ridge's line of sight";
  // The margin (2% of the radius) holds at the points the view samples, every 1.3 m here; in
  // between, at least half of it.
  EXPECT_GE(lowest_clearance(c, s, ridge), 0.01 * s.radius_m);
  // Every angle of the orbit clears rough ground too.
  const GroundFn rough = [](double x, double y) { return 300.0 * std::sin(x / 97.0) * std::cos(y / 131.0); };
  for (double a = 0; a < 6.28; a += 0.5)
    EXPECT_GE(lowest_clearance(orbit_view(s, a, rough), s, rough), 0.01 * s.radius_m) << a;
}

TEST(StartView, AWalkerSpawnsUnderTheEyeOrOnTheRimWhenTheEyeIsPastTheEdge) {
  const WorldParams p = world(1.0, 4, 4);  // 1024 m
  EXPECT_EQ(walker_spawn(p, 500.0, 600.0), (std::array<double, 2>{500.0, 600.0}));
  EXPECT_EQ(walker_spawn(p, -300.0, 5000.0), (std::array<double, 2>{1.0, 1022.0}));
  EXPECT_EQ(walker_spawn(p, 2e6, -1e9), (std::array<double, 2>{1022.0, 1.0}));
}

}  // namespace
}  // namespace loam::scene

namespace loam::view {
namespace {

TEST(StampTool, GrowingStaysInTheRangeTheWorldSets) {
  controls::StampTool tool;
  tool.select(controls::Tool::kCrater);
  tool.min_radius_m = 45.0;
  tool.max_radius_m = 45000.0;
  tool.set_radius(5000.0);
  EXPECT_DOUBLE_EQ(tool.radius_m, 5000.0) << "a 90 m DEM's crater may be kilometres wide";
  tool.grow(1e6);
  EXPECT_DOUBLE_EQ(tool.radius_m, 45000.0);
  tool.grow(1e-9);
  EXPECT_DOUBLE_EQ(tool.radius_m, 45.0);
  EXPECT_NEAR(tool.intensity, 0.25 * 45.0, 1e-9) << "the crater keeps its proportions";
}

}  // namespace
}  // namespace loam::view
