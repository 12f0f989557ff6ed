// The projected vertical error (client/lod/projected_error.h): the bound holds for every point
// of a box on screen, measured through the camera's own view-projection (not the bound's
// formula), from level, pitched and steep views; it is tight at the screen's centre; boxes off
// screen move nothing; without the view's axes it is the distance's bound.
#include "client/lod/projected_error.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "client/scene/camera.h"

namespace loam::lod {
namespace {

constexpr int32_t kWidth = 1920, kHeight = 1080;

LodView view_of(const scene::Camera& cam) {
  LodView v;
  v.x = cam.x, v.y = cam.y, v.z = cam.z;
  v.pixels_per_radian = pixels_per_radian(kHeight, cam.fov_y_degrees);
  set_view_axes(v, {cam.fx, cam.fy, cam.fz}, {cam.ux, cam.uy, cam.uz}, cam.fov_y_degrees,
                double(kWidth) / kHeight);
  return v;
}

// Where the camera draws a world point (pixels), if on screen.
std::optional<std::array<double, 2>> screen(const scene::Camera& cam, const std::array<double, 3>& p) {
  const glm::mat4 vp = scene::view_projection(cam, kWidth, kHeight);
  // The render frame: camera at the origin, world y flipped.
  const glm::dvec4 c = glm::dmat4(vp) * glm::dvec4(p[0] - cam.x, -(p[1] - cam.y), p[2] - cam.z, 1.0);
  if (!(c.w > 0)) return std::nullopt;
  const double nx = c.x / c.w, ny = c.y / c.w;
  if (std::abs(nx) > 1 || std::abs(ny) > 1) return std::nullopt;
  return std::array<double, 2>{(nx + 1) * 0.5 * kWidth, (ny + 1) * 0.5 * kHeight};
}

// Pixels a point's image moves per meter it is raised (a millimetre's move, scaled).
double measured_motion(const scene::Camera& cam, const std::array<double, 3>& p) {
  const auto a = screen(cam, p), b = screen(cam, {p[0], p[1], p[2] + 1e-3});
  if (!a || !b) return 0;
  return std::hypot((*b)[0] - (*a)[0], (*b)[1] - (*a)[1]) / 1e-3;
}

TEST(ProjectedError, TheBoundHoldsForEveryPointOfABoxOnScreen) {
  const std::vector<scene::Camera> cams = {
      scene::look_at(0, 0, 2, 100, 10, -7),     // a walk, 5 degrees down
      scene::look_at(0, 0, 400, 600, 300, 0),   // a flight, 30 degrees down
      scene::look_at(0, 0, 900, 200, -100, 0),  // steep
      scene::look_at(0, 0, 50, 100, 0, 80),     // looking up a slope
  };
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pos(-1500, 1500), size(1, 200), height(-300, 600);
  int on_screen = 0;
  for (const scene::Camera& cam : cams) {
    const LodView v = view_of(cam);
    for (int b = 0; b < 400; ++b) {
      const std::array<double, 3> lo{pos(rng), pos(rng), height(rng)};
      const double s = size(rng);
      const std::array<double, 3> hi{lo[0] + s, lo[1] + s, lo[2] + size(rng)};
      const double bound = pixels_per_vertical_meter(v, lo, hi);
      double worst = 0;
      for (int k = 0; k < 125; ++k) {
        const std::array<double, 3> p{lo[0] + (hi[0] - lo[0]) * (k % 5) / 4.0,
                                      lo[1] + (hi[1] - lo[1]) * (k / 5 % 5) / 4.0,
                                      lo[2] + (hi[2] - lo[2]) * (k / 25) / 4.0};
        worst = std::max(worst, measured_motion(cam, p));
      }
      if (worst > 0) ++on_screen;
      EXPECT_LE(worst, bound * (1 + 1e-4) + 1e-9) << "camera " << &cam - cams.data() << ", box " << b;
    }
  }
  EXPECT_GT(on_screen, 300);  // the boxes tested are mostly in view
}

TEST(ProjectedError, ThePointAtTheScreensCentreIsBoundTightly) {
  for (const scene::Camera& cam :
       {scene::look_at(0, 0, 2, 100, 0, -6.75), scene::look_at(0, 0, 400, 600, 0, 0)}) {
    const LodView v = view_of(cam);
    const std::array<double, 3> p{cam.x + cam.fx, cam.y + cam.fy, cam.z + cam.fz};
    const double bound = pixels_per_vertical_meter(v, p, p);
    EXPECT_NEAR(bound, measured_motion(cam, p), 1e-3 * bound);
  }
}

TEST(ProjectedError, BoxesOffScreenMoveNothingAndTheEyeInABoxIsUnbounded) {
  const scene::Camera cam = scene::look_at(0, 0, 100, 1000, 0, 0);
  const LodView v = view_of(cam);
  EXPECT_EQ(pixels_per_vertical_meter(v, {-500, -50, 0}, {-400, 50, 50}), 0.0);   // behind
  EXPECT_EQ(pixels_per_vertical_meter(v, {500, 2000, 0}, {600, 2100, 50}), 0.0);  // far to the side
  EXPECT_EQ(pixels_per_vertical_meter(v, {-10, -10, 90}, {10, 10, 110}),
            std::numeric_limits<double>::infinity());
  // Across the eye's plane: bounded by the screen's corner at the box's distance.
  EXPECT_GT(pixels_per_vertical_meter(v, {-50, 20, 90}, {50, 30, 110}), 0.0);
}

TEST(ProjectedError, WithoutTheViewsAxesTheBoundIsTheDistancesAlone) {
  LodView v;
  v.x = 0, v.y = 0, v.z = 100;
  v.pixels_per_radian = 1000;
  EXPECT_DOUBLE_EQ(pixels_per_vertical_meter(v, {300, -10, 0}, {400, 10, 200}), 1000.0 / 300.0);
}

}  // namespace
}  // namespace loam::lod
