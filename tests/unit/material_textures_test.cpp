// The generated material textures: seamless, half-bright on average, distinct, the same bytes
// every time; and the sun's shadow frame.
#include "client/scene/material_textures.h"

#include <gtest/gtest.h>

#include <cmath>
#include <glm/glm.hpp>

#include "client/scene/sun_shadow.h"

namespace loam::scene {
namespace {

constexpr int32_t kSize = 128;

double channel_step(const std::vector<uint8_t>& t, int32_t x0, int32_t x1) {
  double sum = 0;
  for (int32_t y = 0; y < kSize; ++y)
    for (int k = 0; k < 3; ++k)
      sum += std::abs(double(t[size_t(y * kSize + x0) * 4 + size_t(k)]) -
                      t[size_t(y * kSize + x1) * 4 + size_t(k)]);
  return sum / (kSize * 3);
}

TEST(MaterialTextures, EveryLayerTilesWithoutASeamAndAveragesHalfBright) {
  for (int32_t m = 0; m < kMaterialCount; ++m) {
    const std::vector<uint8_t> t = material_texture(Material(m), kSize);
    ASSERT_EQ(t.size(), size_t(kSize * kSize * 4));
    // Across the wrap (last column to the first) the texture steps no more than between
    // neighbouring columns inside it.
    double inside = 0;
    for (int32_t x = 0; x + 1 < kSize; ++x) inside += channel_step(t, x, x + 1);
    inside /= kSize - 1;
    EXPECT_LT(channel_step(t, kSize - 1, 0), 2.0 * inside + 1.0) << to_string(Material(m));
    double mean = 0;
    for (size_t i = 0; i < t.size(); i += 4) mean += (t[i] + t[i + 1] + t[i + 2]) / 3.0;
    mean /= double(kSize * kSize);
    EXPECT_NEAR(mean, 127.5, 4.0) << to_string(Material(m));
    EXPECT_EQ(t, material_texture(Material(m), kSize)) << "deterministic";
  }
  EXPECT_NE(material_texture(Material::kRock, kSize), material_texture(Material::kEarth, kSize));
}

TEST(SunShadow, PointsAroundTheCameraLandInsideTheMapWithDepthRisingTowardTheSun) {
  Camera cam = look_at(5000, 7000, 300, 5400, 7000, 250);
  const glm::dvec3 to_sun = glm::normalize(glm::dvec3(0.5, 0.5, 0.7));
  const SunShadowFrame f = sun_shadow_frame(cam, to_sun, 1000, 0, 400, 2048);
  EXPECT_NEAR(f.texel_m, 2000.0 / 2048, 1e-12);
  auto clip = [&](double x, double y, double z) {
    // Render frame: relative to the camera, y north = -world y.
    return f.light_view_proj * glm::vec4(float(x - cam.x), float(-(y - cam.y)), float(z - cam.z), 1.0f);
  };
  for (double dx : {-450.0, 0.0, 450.0}) {  // the map's centre is a third of its radius ahead
    for (double dy : {-450.0, 0.0, 450.0}) {
      const glm::vec4 c = clip(cam.x + dx, cam.y + dy, 200);
      EXPECT_LT(std::abs(c.x), 1.0f);
      EXPECT_LT(std::abs(c.y), 1.0f);
      EXPECT_GT(c.z, 0.0f);
      EXPECT_LT(c.z, 1.0f);
    }
  }
  // Higher along the sun's direction: nearer the sun, larger (reversed) depth.
  const glm::vec4 low = clip(cam.x, cam.y, 0), high = clip(cam.x, cam.y, 400);
  EXPECT_GT(high.z, low.z);
}

TEST(SunShadow, TheMapSlidesByWholeTexelsAsTheCameraMoves) {
  const glm::dvec3 to_sun = glm::normalize(glm::dvec3(-0.3, 0.6, 0.5));
  Camera a = look_at(1000, 1000, 100, 1100, 1000, 90);
  Camera b = a;
  b.x += 3.3, b.y -= 1.7;
  const SunShadowFrame fa = sun_shadow_frame(a, to_sun, 800, 0, 200, 1024);
  const SunShadowFrame fb = sun_shadow_frame(b, to_sun, 800, 0, 200, 1024);
  // A fixed world point lands at texel coordinates that differ by whole texels.
  const glm::dvec3 p(1200, 900, 50);
  auto texel = [&](const SunShadowFrame& f, const Camera& c) {
    const glm::vec4 q =
        f.light_view_proj * glm::vec4(float(p.x - c.x), float(-(p.y - c.y)), float(p.z - c.z), 1.0f);
    return glm::dvec2((q.x * 0.5 + 0.5) * 1024, (q.y * 0.5 + 0.5) * 1024);
  };
  const glm::dvec2 d = texel(fa, a) - texel(fb, b);
  EXPECT_NEAR(d.x, std::round(d.x), 0.02);
  EXPECT_NEAR(d.y, std::round(d.y), 0.02);
}

}  // namespace
}  // namespace loam::scene
