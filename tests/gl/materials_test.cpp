// Materials and light that follow deformation: a crater dug in the embedded terrain shows exposed
// earth (the change layer against the undug terrain) and, under a low sun, the shadow of its
// rim on its floor; moving the sun moves the shadow. Measured on the rendered pixels of both
// renderers (the classic clipmap and the error-driven one share the look: terrain_look.h),
// plus goldens of the crater with and without materials and shadows.
#include <epoxy/gl.h>
#include <gtest/gtest.h>

#include <cmath>
#include <ostream>

#include "client/render/clipmap_renderer.h"
#include "client/render/error_clipmap_renderer.h"
#include "client/render/lod_scheme.h"
#include "client/render/offscreen_target.h"
#include "dem/default_terrain.h"
#include "gl_test_context.h"
#include "golden_image.h"
#include "gpu/egl_context.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/surface.h"

namespace loam::render {
namespace {

constexpr int32_t kWidth = 320, kHeight = 180;
// Flat around the crater: no ridge within 1.5 km rises above 4 degrees seen from the east.
constexpr double kCraterX = 1200, kCraterY = 486, kCraterRadius = 30, kCraterDepth = 8;

struct Scene {
  World plain, dug;
};

const Scene& scene() {
  static const Scene s = [] {
    auto imported = load_default_terrain();
    EXPECT_TRUE(imported.ok());
    Scene out{imported->world, imported->world};
    StampParams c;
    c.kind = StampKind::kCrater;
    c.center_x = kCraterX, c.center_y = kCraterY, c.radius = kCraterRadius, c.intensity = kCraterDepth;
    c.shape = 0.3;
    auto q = validate_stamp(c, out.dug.params());
    EXPECT_TRUE(q.ok());
    EXPECT_TRUE(apply_stamp(out.dug, *q).ok());
    out.dug.commit(1);
    return out;
  }();
  return s;
}

// A view down into the crater from the south, 70 m out.
scene::Camera crater_view(const World& w) {
  scene::Camera cam =
      scene::look_at(kCraterX, kCraterY + 70, height_at(w, kCraterX, kCraterY + 70) + 40, kCraterX, kCraterY,
                     height_at(scene().plain, kCraterX, kCraterY) - kCraterDepth * 0.5);
  cam.far_m = 8000;
  return cam;
}

// `cfg`'s look, detail and view distance drawn by the scheme's renderer.
std::vector<uint8_t> render(const terrain::HeightSource& source, const scene::Camera& cam,
                            const RendererConfig& cfg, LodScheme scheme = LodScheme::kClassic) {
  auto target = OffscreenTarget::create(kWidth, kHeight);
  EXPECT_TRUE(target.ok());
  target->begin(0.50f, 0.60f, 0.75f, 0.0f);
  if (scheme == LodScheme::kClassic) {
    auto renderer = ClipmapRenderer::create(source, cfg);
    EXPECT_TRUE(renderer.ok());
    (*renderer)->render(cam, kWidth, kHeight);
  } else {
    ErrorClipmapConfig ec;
    ec.look = cfg.look;
    ec.detail_size = cfg.detail_size;
    ec.view_distance = cfg.view_distance;
    ec.region =
        256;  // the crater's surroundings at every level, and a quarter of the error bounds to compute
    auto renderer = ErrorClipmapRenderer::create(source, ec);
    EXPECT_TRUE(renderer.ok()) << renderer.error().describe();
    (*renderer)->render(cam, kWidth, kHeight);
  }
  return target->read_rgba();
}

class MaterialsOf : public ::testing::TestWithParam<LodScheme> {};

}  // namespace

// gtest prints the parameter by name (test listings, ctest).
void PrintTo(LodScheme s, std::ostream* os) { *os << to_string(s); }

namespace {

// Mean of a channel expression over the image's centre (the crater's floor and walls; `half`
// pixels either way).
template <typename F>
double centre_mean(const std::vector<uint8_t>& rgba, F f, int half = kHeight / 6) {
  double sum = 0;
  int n = 0;
  for (int y = kHeight / 2 - half; y < kHeight / 2 + half; ++y) {
    for (int x = kWidth / 2 - half; x < kWidth / 2 + half; ++x, ++n) {
      const uint8_t* p = &rgba[size_t(y * kWidth + x) * 4];
      sum += f(double(p[0]), double(p[1]), double(p[2]));
    }
  }
  return sum / n;
}

double luminance(double r, double g, double b) { return 0.2126 * r + 0.7152 * g + 0.0722 * b; }

TEST_P(MaterialsOf, DugGroundReadsAsEarthWhereTheTerrainChangedAgainstItsInitialState) {
  LOAM_REQUIRE_GL();
  const LodScheme scheme = GetParam();
  const Scene& s = scene();
  RendererConfig cfg;
  cfg.look.shadows = false;
  const scene::Camera cam = crater_view(s.dug);
  const terrain::WorldHeightSource knows_initial(s.dug, &s.plain), no_initial(s.dug);
  const auto with_layer = render(knows_initial, cam, cfg, scheme),
             without = render(no_initial, cam, cfg, scheme);
  // Earth is redder than the basin's sand and dry grass: red minus blue rises inside the crater.
  auto warmth = [](double r, double, double b) { return r - b; };
  const double dug = centre_mean(with_layer, warmth), plain = centre_mean(without, warmth);
  EXPECT_GT(dug, plain + 6.0) << "dug " << dug << ", without the change layer " << plain;
  // The same source on the undug terrain: nothing changed, nothing reads as dug.
  const terrain::WorldHeightSource undug(s.plain, &s.plain), undug_plain(s.plain);
  const scene::Camera plain_cam = crater_view(s.plain);
  EXPECT_NEAR(centre_mean(render(undug, plain_cam, cfg, scheme), warmth),
              centre_mean(render(undug_plain, plain_cam, cfg, scheme), warmth), 0.01);
}

TEST_P(MaterialsOf, UnderALowSunTheCraterRimShadowsItsFloorAndTheShadowMovesWithTheSun) {
  LOAM_REQUIRE_GL();
  const LodScheme scheme = GetParam();
  const Scene& s = scene();
  RendererConfig shadowed;
  shadowed.look.sun_elevation_degrees = 12;
  shadowed.look.sun_azimuth_degrees = 90;  // from the east: the east rim shadows the floor
  RendererConfig lit = shadowed;
  lit.look.shadows = false;
  // How much the shadows darken the view's centre, on the dug and on the undug terrain.
  auto darkening = [&](const World& w, const World* initial, const RendererConfig& on,
                       const RendererConfig& off) {
    const terrain::WorldHeightSource source(w, initial);
    const scene::Camera cam = crater_view(w);
    // The crater's floor: the picture's centre, 16 pixels either way.
    return centre_mean(render(source, cam, off, scheme), luminance, 16) -
           centre_mean(render(source, cam, on, scheme), luminance, 16);
  };
  const double crater = darkening(s.dug, &s.plain, shadowed, lit);
  const double flat = darkening(s.plain, &s.plain, shadowed, lit);
  std::printf("%s: low sun: shadows darken the crater by %.2f, the undug ground by %.2f\n",
              std::string(to_string(scheme)).c_str(), crater, flat);
  EXPECT_GT(crater, flat + 5.0) << "the rim's shadow on the floor";
  // A high sun leaves the floor lit: the shadow follows the sun.
  RendererConfig noon = shadowed, noon_lit = lit;
  noon.look.sun_elevation_degrees = noon_lit.look.sun_elevation_degrees = 75;
  const double at_noon = darkening(s.dug, &s.plain, noon, noon_lit);
  std::printf("high sun: shadows darken the crater by %.2f\n", at_noon);
  EXPECT_LT(at_noon, 0.25 * crater);
}

INSTANTIATE_TEST_SUITE_P(BothRenderers, MaterialsOf,
                         ::testing::Values(LodScheme::kClassic, LodScheme::kError),
                         [](const auto& p) { return std::string(to_string(p.param)); });

TEST(MaterialsGolden, ADugCraterUnderALowSunWithAndWithoutMaterialsAndShadows) {
  LOAM_REQUIRE_GL();
  LOAM_REQUIRE_IDIFF();
  const Scene& s = scene();
  const scene::Camera cam = crater_view(s.dug);
  const terrain::WorldHeightSource dug(s.dug, &s.plain);
  RendererConfig cfg;
  cfg.look.sun_elevation_degrees = 14;
  cfg.look.sun_azimuth_degrees = 90;
  test::compare_with_golden("materials_dug_crater_low_sun", kWidth, kHeight, render(dug, cam, cfg));
  RendererConfig bare = cfg;
  bare.look.materials = false;
  bare.look.shadows = false;
  test::compare_with_golden("materials_off_dug_crater_low_sun", kWidth, kHeight, render(dug, cam, bare));
}

TEST(Materials, AnisotropyOutsideItsRangeIsRefused) {
  LOAM_REQUIRE_GL();
  const terrain::WorldHeightSource source(scene().plain);
  for (float bad : {-1.0f, 0.5f, 16.5f, std::nanf(""), INFINITY}) {
    RendererConfig cfg;
    cfg.look.anisotropy = bad;
    auto r = ClipmapRenderer::create(source, cfg);
    ASSERT_FALSE(r.ok()) << bad;
    EXPECT_EQ(r.error().code, ErrorCode::kInvalidArgument);
  }
  for (float good : {0.0f, 1.0f, 16.0f}) {
    RendererConfig cfg;
    cfg.look.anisotropy = good;
    EXPECT_TRUE(ClipmapRenderer::create(source, cfg).ok()) << good;
  }
}

// Auto: a software rasterizer pays for every anisotropic tap (seven times the frame on
// llvmpipe), a GPU barely does; an explicit value is taken where the driver filters.
TEST(Materials, AutoAnisotropyIsTrilinearOnASoftwareRasterizerAndEightOnAGpu) {
  LOAM_REQUIRE_GL();
  const terrain::WorldHeightSource source(scene().plain);
  const bool has_aniso = epoxy_has_gl_extension("GL_EXT_texture_filter_anisotropic") ||
                         epoxy_has_gl_extension("GL_ARB_texture_filter_anisotropic");
  const bool software = gpu::is_software_renderer(reinterpret_cast<const char*>(glGetString(GL_RENDERER)));
  RendererConfig cfg;
  auto automatic = ClipmapRenderer::create(source, cfg);
  ASSERT_TRUE(automatic.ok());
  EXPECT_EQ((*automatic)->anisotropy(), software || !has_aniso ? 1.0f : 8.0f);
  cfg.look.anisotropy = 4;
  auto explicit_four = ClipmapRenderer::create(source, cfg);
  ASSERT_TRUE(explicit_four.ok());
  EXPECT_EQ((*explicit_four)->anisotropy(), has_aniso ? 4.0f : 1.0f);
}

}  // namespace
}  // namespace loam::render
