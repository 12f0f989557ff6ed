// Frustum culling (client/scene/frustum.h): the planes of the renderer's own view-projection,
// and boxes kept or culled as a camera sees them. Conservative: a box any visible point of
// which lies inside is never culled.
#include "client/scene/frustum.h"

#include <gtest/gtest.h>

#include <random>

#include "client/scene/camera.h"

namespace loam::scene {
namespace {

// A camera 100 m up looking east (+x) level, 90 degrees vertical field of view at 16:9.
struct Eastward {
  Camera cam = [] {
    Camera c = look_at(0, 0, 100, 100, 0, 100);
    c.fov_y_degrees = 90;
    c.near_m = 1;
    c.far_m = 1000;
    return c;
  }();
  glm::mat4 vp = view_projection(cam, 1600, 900);
  Frustum f = frustum_of(vp);
  // In the render frame the camera is at the origin: x east, y north (world -y), z up.
  bool culled(glm::vec3 lo, glm::vec3 hi) const { return box_outside(f, lo, hi); }
};

TEST(Frustum, ABoxAheadIsKeptAndOneBehindTheCameraIsCulled) {
  const Eastward e;
  EXPECT_FALSE(e.culled({50, -5, -5}, {60, 5, 5}));
  EXPECT_TRUE(e.culled({-60, -5, -5}, {-50, 5, 5}));
}

TEST(Frustum, BoxesBeyondTheFarPlaneOrBeforeTheNearPlaneAreCulled) {
  const Eastward e;
  EXPECT_TRUE(e.culled({1001, -1, -1}, {1100, 1, 1}));
  EXPECT_FALSE(e.culled({990, -1, -1}, {1100, 1, 1}));  // reaches inside the far plane
  EXPECT_TRUE(e.culled({0.1f, -0.01f, -0.01f}, {0.5f, 0.01f, 0.01f}));
}

TEST(Frustum, BoxesOutsideTheSidesAreCulledAndOnesStraddlingThemKept) {
  const Eastward e;
  // 90 degrees vertically at 16:9: d m ahead the view reaches d m up and down, 1.78 d sideways
  // (187 m at the boxes' far side).
  EXPECT_TRUE(e.culled({95, -5, 110}, {105, 5, 120}));    // above
  EXPECT_TRUE(e.culled({95, -5, -120}, {105, 5, -110}));  // below
  EXPECT_TRUE(e.culled({95, 190, -5}, {105, 200, 5}));    // north, off the left edge
  EXPECT_TRUE(e.culled({95, -200, -5}, {105, -190, 5}));  // south, off the right edge
  EXPECT_FALSE(e.culled({95, 170, -5}, {105, 195, 5}));   // straddles the left edge
  EXPECT_FALSE(e.culled({95, -5, 90}, {105, 5, 120}));    // straddles the top
}

TEST(Frustum, ABoxAroundTheCameraIsKept) {
  const Eastward e;
  EXPECT_FALSE(e.culled({-10, -10, -10}, {10, 10, 10}));
}

TEST(Frustum, NoBoxWithAVisiblePointIsCulled) {
  // Random cameras and boxes: wherever a point of the box projects inside clip space, the box
  // is kept. (The converse does not hold: the test is conservative near frustum corners.)
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1, 1);
  int kept_visible = 0, culled = 0;
  for (int c = 0; c < 50; ++c) {
    Camera cam = look_at(0, 0, 0, 100 * u(rng), 100 * u(rng), 100 * u(rng) + 0.5f);
    cam.fov_y_degrees = 30 + 60 * (u(rng) + 1) / 2;
    cam.far_m = 500;
    const glm::mat4 vp = view_projection(cam, 1280, 720);
    const Frustum f = frustum_of(vp);
    for (int b = 0; b < 200; ++b) {
      const glm::vec3 centre(300 * u(rng), 300 * u(rng), 300 * u(rng));
      const glm::vec3 half(1 + 40 * (u(rng) + 1), 1 + 40 * (u(rng) + 1), 1 + 40 * (u(rng) + 1));
      const glm::vec3 lo = centre - half, hi = centre + half;
      bool visible = false;
      for (int i = 0; i <= 6 && !visible; ++i) {
        for (int j = 0; j <= 6 && !visible; ++j) {
          for (int k = 0; k <= 6 && !visible; ++k) {
            const glm::vec3 p = lo + (hi - lo) * glm::vec3(float(i), float(j), float(k)) / 6.0f;
            const glm::vec4 q = vp * glm::vec4(p, 1);
            visible = q.w > 0 && std::abs(q.x) <= q.w && std::abs(q.y) <= q.w && std::abs(q.z) <= q.w;
          }
        }
      }
      const bool out = box_outside(f, lo, hi);
      if (visible) {
        ++kept_visible;
        EXPECT_FALSE(out) << "camera " << c << " box " << b;
      }
      culled += out;
    }
  }
  // Both outcomes occur, so the check above is not vacuous.
  EXPECT_GT(kept_visible, 500);
  EXPECT_GT(culled, 2000);
}

}  // namespace
}  // namespace loam::scene
