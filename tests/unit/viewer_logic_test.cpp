// The viewer's pure logic: the fly camera moves where it looks, turns right with the mouse
// moving right, never goes below the ground; picking inverts the projection the renderer
// draws with; every stamp tool gives a stamp the world validates.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/glm.hpp>

#include "client/controls/fly_camera.h"
#include "client/controls/stamp_tool.h"
#include "client/scene/camera.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/stamps/texture_registry.h"

namespace loam::view {
namespace {

TEST(FlyCamera, MovesAlongItsViewTurnsRightWithTheMouseAndStaysAboveGround) {
  controls::FlyCamera c = controls::FlyCamera::looking_at(0, 0, 100, 10, 0, 100);  // along +x, level
  c.set_speed(10);
  auto flat = [](double, double) { return 50.0; };
  c.update({.forward = 1}, 1.0, flat);
  EXPECT_NEAR(c.x(), 10.0, 1e-9);
  EXPECT_NEAR(c.y(), 0.0, 1e-9);
  // Right of +x, seen from above with y along +gy (south), is +y.
  c.update({.right = 1}, 1.0, flat);
  EXPECT_NEAR(c.y(), 10.0, 1e-9);
  const double yaw = c.yaw();
  c.update({.turn_x = 100}, 0.0, flat);
  EXPECT_GT(c.yaw(), yaw);
  c.update({.up = -1, .fast = true}, 10.0, flat);  // 800 m down: stopped 2 m above the ground
  EXPECT_NEAR(c.z(), 52.0, 1e-9);
  const scene::Camera cam = c.camera();
  EXPECT_NEAR(std::hypot(cam.fx, cam.fy, cam.fz), 1.0, 1e-9);
}

TEST(FlyCamera, PitchStopsShortOfStraightUpAndDown) {
  controls::FlyCamera c;
  c.update({.turn_y = -1e6}, 0.0, nullptr);
  EXPECT_LT(c.pitch(), 1.5708);
  c.update({.turn_y = 1e6}, 0.0, nullptr);
  EXPECT_GT(c.pitch(), -1.5708);
}

TEST(Picking, UnprojectFindsThePointThatProjectsToThePixel) {
  scene::Camera cam = scene::look_at(1000.5, -2000.25, 300, 1100, -1900, 20);
  const int32_t w = 640, h = 360;
  const glm::mat4 vp = scene::view_projection(cam, w, h);
  for (const auto& p : {std::array<double, 3>{1100, -1900, 20}, std::array<double, 3>{1040, -1980, 55}}) {
    // Where p lands (render frame: camera-relative, y flipped).
    const glm::vec4 clip =
        vp * glm::vec4(float(p[0] - cam.x), float(-(p[1] - cam.y)), float(p[2] - cam.z), 1.0f);
    const glm::vec3 ndc = glm::vec3(clip) / clip.w;
    const double px = (ndc.x + 1.0) * 0.5 * w - 0.5, py = (1.0 - ndc.y) * 0.5 * h - 0.5;
    const auto back = scene::unproject(cam, w, h, px, py, ndc.z);  // clip z 0..w: window depth is ndc z
    ASSERT_TRUE(back.has_value());
    EXPECT_NEAR((*back)[0], p[0], 0.05);
    EXPECT_NEAR((*back)[1], p[1], 0.05);
    EXPECT_NEAR((*back)[2], p[2], 0.05);
  }
  EXPECT_FALSE(scene::unproject(cam, w, h, 10, 10, scene::kBackgroundDepth).has_value())
      << "depth 0 is the background";
}

// Reversed depth: the near plane at 1, the far plane at 0, and view_distance inverts it for
// both lenses.
TEST(Picking, ViewDistanceInvertsTheReversedDepthOfBothLenses) {
  for (const bool ortho : {false, true}) {
    scene::Camera cam = scene::look_at(0, 0, 0, 1, 0, 0);
    cam.near_m = 0.5, cam.far_m = 40000, cam.ortho_half_height = ortho ? 100.0 : 0.0;
    const glm::mat4 vp = scene::view_projection(cam, 800, 600);
    for (const double d : {0.5, 3.0, 250.0, 9000.0, 40000.0}) {
      const glm::vec4 clip = vp * glm::vec4(float(d), 0.0f, 0.0f, 1.0f);
      const float depth = clip.z / clip.w;
      EXPECT_NEAR(scene::view_distance(cam, depth), d, 1e-5 * d + (ortho ? 0.01 : 0.0))
          << (ortho ? "ortho " : "perspective ") << d;
    }
    EXPECT_NEAR(scene::view_distance(cam, 1.0f), cam.near_m, 1e-9);
    EXPECT_NEAR(scene::view_distance(cam, 0.0f), cam.far_m, 1e-6);
  }
}

// Behind a 0.5 m near plane, a float depth read at 10 km places the point within centimetres:
// a depth read at a far silhouette lands on the terrain, not metres behind it.
TEST(Picking, ReversedFloatDepthResolvesCentimetresTenKilometresAway) {
  scene::Camera cam = scene::look_at(0, 0, 0, 1, 0, 0);
  cam.near_m = 0.5, cam.far_m = 40000;
  const glm::mat4 vp = scene::view_projection(cam, 800, 600);
  const glm::vec4 clip = vp * glm::vec4(10000.0f, 0.0f, 0.0f, 1.0f);
  const float depth = clip.z / clip.w;
  const float next = std::nextafter(depth, 1.0f);  // one float step nearer
  EXPECT_LT(scene::view_distance(cam, depth) - scene::view_distance(cam, next), 0.01);
  const auto back = scene::unproject(cam, 800, 600, 399.5, 299.5, depth);
  ASSERT_TRUE(back.has_value());
  EXPECT_NEAR((*back)[0], 10000.0, 0.05);
}

// `loam-client render --camera X --look X` used to draw from a NaN view matrix: a camera on
// its look point, a non-finite coordinate or a vertical view (parallel to the up vector) has
// no look-at matrix, and each is named instead.
TEST(Camera, LookAtProblemNamesACameraAtItsLookPointANonFiniteCoordinateAndAVerticalView) {
  using scene::look_at_problem;
  EXPECT_FALSE(look_at_problem(1024, 1700, 300, 1024, 800, 60).has_value());
  const auto same = look_at_problem(10, 20, 30, 10, 20, 30);
  ASSERT_TRUE(same.has_value());
  EXPECT_NE(same->find("look point"), std::string::npos) << *same;
  const auto nan = look_at_problem(std::nan(""), 20, 30, 0, 0, 0);
  ASSERT_TRUE(nan.has_value());
  EXPECT_NE(nan->find("finite"), std::string::npos) << *nan;
  EXPECT_TRUE(look_at_problem(0, 0, 0, INFINITY, 0, 0).has_value());
  const auto down = look_at_problem(100, 100, 500, 100, 100, 0);
  ASSERT_TRUE(down.has_value());
  EXPECT_NE(down->find("straight up or down"), std::string::npos) << *down;
  // Where the check passes, the view-projection matrix is finite.
  const glm::mat4 m = scene::view_projection(scene::look_at(100, 100, 500, 101, 100, 0), 640, 480);
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r) EXPECT_TRUE(std::isfinite(m[c][r]));
}

TEST(StampTool, EveryToolGivesAStampTheWorldValidates) {
  WorldParams w;
  w.meters_per_sample = 2.0;
  w.tiles_x = 4;
  w.tiles_y = 3;
  w.height_offset = -100;
  w.meters_per_unit = 0.01;
  controls::StampTool tool;
  for (double radius : {0.5, 8.0, 120.0}) {
    for (int t = 0; t < controls::kToolCount; ++t) {
      tool.radius_m = radius;
      tool.select(controls::Tool(t));
      const StampParams p = tool.at(700, 600, 12.5);
      auto q = validate_stamp(p, w);
      EXPECT_TRUE(q.ok()) << to_string(controls::Tool(t)) << " radius " << radius << ": "
                          << (q.ok() ? "" : q.error().describe());
      EXPECT_EQ(p.layer, controls::Tool(t) == controls::Tool::kFootprint ? Layer::kDetail : Layer::kCoarse);
    }
  }
  tool.grow(1e6);
  EXPECT_EQ(tool.radius_m, 500.0);
}

// The tool panel can send any kind with any blend: the fields a kind does not have stay unset,
// so every combination the panel offers validates (texture stamps with a registered image).
TEST(StampTool, EveryKindAndBlendThePanelOffersValidates) {
  WorldParams w;
  w.meters_per_sample = 2.0;
  w.tiles_x = 4;
  w.tiles_y = 3;
  w.height_offset = -100;
  w.meters_per_unit = 0.01;
  TextureRegistry textures;
  std::vector<uint16_t> img(16 * 16);
  for (size_t i = 0; i < img.size(); ++i) img[i] = uint16_t(i * 200);
  const uint64_t id = *textures.add(16, 16, img);
  for (int k = 0; k < kStampKindCount; ++k) {
    for (int b = 0; b < kBlendModeCount; ++b) {
      controls::StampTool tool;
      tool.select(controls::Tool::kCrater);
      tool.set_kind(StampKind(k));
      tool.blend = BlendMode(b);
      tool.texture_id = id;
      tool.rotation_degrees = 30;
      const bool own = tool.kind == StampKind::kFootprint || tool.kind == StampKind::kFlatten ||
                       tool.kind == StampKind::kShockwave;
      auto q = validate_stamp(tool.at(700, 600, 12.5), w, {}, &textures);
      if (own && tool.blend != BlendMode::kAdd) {
        EXPECT_FALSE(q.ok()) << to_string(tool.kind) << " " << to_string(tool.blend);
        continue;
      }
      EXPECT_TRUE(q.ok()) << to_string(tool.kind) << " " << to_string(tool.blend) << ": "
                          << (q.ok() ? "" : q.error().describe());
    }
  }
  // The volume-conserving crater, which the presets never send.
  controls::StampTool crater;
  crater.select(controls::Tool::kCrater);
  crater.volume_conserving = true;
  auto q = validate_stamp(crater.at(700, 600, 12.5), w);
  ASSERT_TRUE(q.ok()) << q.error().describe();
  EXPECT_EQ(q->flags & kStampFlagVolumeConserving, kStampFlagVolumeConserving);
}

TEST(StampTool, GrowingAPresetKeepsItsProportions) {
  controls::StampTool tool;
  tool.radius_m = 8;
  tool.select(controls::Tool::kCrater);
  tool.grow(2.0);
  EXPECT_DOUBLE_EQ(tool.radius_m, 16.0);
  EXPECT_DOUBLE_EQ(tool.intensity, 4.0);
  tool.select(controls::Tool::kFlatten);
  tool.grow(2.0);
  EXPECT_DOUBLE_EQ(tool.intensity, 0.8);  // a strength, not a height
}

}  // namespace
}  // namespace loam::view
