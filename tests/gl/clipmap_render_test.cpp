// Clipmap renders of the embedded default terrain on the GL context: no background shows
// through the surface at grazing angles, geomorphing keeps the surface continuous while the
// levels move (and the same path without it jumps), and toroidal strip uploads leave the
// level textures exactly as a fresh full upload would.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "client/render/clipmap_renderer.h"
#include "client/render/offscreen_target.h"
#include "dem/default_terrain.h"
#include "gl_test_context.h"
#include "protocol/normal_map.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/surface.h"

namespace loam::render {
namespace {

const World& default_world() {
  static const World world = [] {
    auto imported = load_default_terrain();
    EXPECT_TRUE(imported.ok());
    return std::move(imported->world);
  }();
  return world;
}

// Columns of an image from a camera with no roll are vertical planes through the camera; on a
// height field every ray below one that hits the ground hits it too. A background pixel
// (alpha 0) below the first terrain pixel of its column is a crack.
int64_t background_below_terrain(const std::vector<uint8_t>& rgba, int32_t w, int32_t h) {
  int64_t holes = 0;
  for (int32_t x = 0; x < w; ++x) {
    bool terrain = false;
    for (int32_t y = 0; y < h; ++y) {
      const bool bg = rgba[(size_t(y) * size_t(w) + size_t(x)) * 4 + 3] == 0;
      if (!bg) terrain = true;
      if (bg && terrain) ++holes;
    }
  }
  return holes;
}

TEST(ClipmapRender, GrazingViewsShowNoBackgroundThroughTheSurface) {
  LOAM_REQUIRE_GL();
  const World& world = default_world();
  terrain::WorldHeightSource source(world);
  RendererConfig cfg;
  cfg.n = 63;
  cfg.view_distance = 3000;
  auto renderer = ClipmapRenderer::create(source, cfg);
  ASSERT_TRUE(renderer.ok()) << renderer.error().describe();
  const int32_t w = 320, h = 200;
  auto target = OffscreenTarget::create(w, h);
  ASSERT_TRUE(target.ok());
  struct View {
    double x, y, dx, dy;
  };
  // Low over valleys and plateau edges, looking along and across the level boundaries.
  const View views[] = {{300, 300, 1, 0.3}, {1500, 1300, -1, -0.8}, {1024, 700, 0.2, 1}, {640, 1100, 1, -1}};
  for (bool morph : {true, false}) {
    (*renderer)->set_morph(morph);
    for (const View& v : views) {
      const double ground = height_at(world, v.x, v.y);
      scene::Camera cam =
          scene::look_at(v.x, v.y, ground + 3.0, v.x + v.dx * 100, v.y + v.dy * 100, ground + 1.0);
      cam.far_m = 20000;
      target->begin(0, 0, 0, 0);
      (*renderer)->render(cam, w, h);
      const auto rgba = target->read_rgba();
      const int64_t holes = background_below_terrain(rgba, w, h);
      EXPECT_EQ(holes, 0) << "view at " << v.x << "," << v.y << " morph " << morph;
      if (holes != 0) {
        const std::string file = "clipmap_grazing_failure_" + std::to_string(int(v.x)) + ".png";
        (void)write_png(file, w, h, rgba, true);
        std::fprintf(stderr, "wrote %s\n", file.c_str());
      }
    }
  }
}

// Height of the rendered surface under every pixel of a straight-down orthographic view.
std::vector<double> surface_heights(ClipmapRenderer& r, const OffscreenTarget& t, scene::Camera cam) {
  t.begin(0, 0, 0, 0);
  r.render(cam, t.width(), t.height());
  const auto depth = t.read_depth();
  std::vector<double> out(depth.size());
  for (size_t i = 0; i < depth.size(); ++i) {
    out[i] = cam.z - scene::view_distance(cam, depth[i]);
  }
  return out;
}

// The camera (the clipmap's centre) moves in quarter-sample steps under a fixed orthographic
// view: every level shifts several times. With geomorphing the surface at fixed world points
// changes by little per step; without it the levels' coarse/fine switches jump.
TEST(ClipmapRender, GeomorphingBoundsSurfaceChangePerCameraStepAndNoMorphJumps) {
  LOAM_REQUIRE_GL();
  const World& world = default_world();
  terrain::WorldHeightSource source(world);
  RendererConfig cfg;
  cfg.n = 31;
  cfg.levels = 4;
  cfg.cull = false;
  auto target = OffscreenTarget::create(240, 240);
  ASSERT_TRUE(target.ok());
  double max_step[2] = {0, 0};
  for (int morph = 0; morph < 2; ++morph) {
    cfg.morph = morph == 1;
    auto renderer = ClipmapRenderer::create(source, cfg);
    ASSERT_TRUE(renderer.ok());
    scene::Camera cam;
    cam.x = 1000, cam.y = 760, cam.z = 1000;
    cam.fx = 0, cam.fy = 0, cam.fz = -1;
    cam.ux = 0, cam.uy = -1, cam.uz = 0;
    cam.ortho_half_height = 110;  // 220 m: levels 0..2 and their bands
    cam.near_m = 1, cam.far_m = 2000;
    std::vector<double> prev;
    for (int step = 0; step <= 64; ++step) {
      cam.lod_center = std::array<double, 2>{1000 + 0.5 * step, 760 + 0.3 * step};
      const auto now = surface_heights(**renderer, *target, cam);
      if (!prev.empty()) {
        for (size_t i = 0; i < now.size(); ++i)
          max_step[morph] = std::max(max_step[morph], std::abs(now[i] - prev[i]));
      }
      prev = now;
    }
  }
  std::printf("largest surface change per 0.5 m camera step: %.3f m morphing, %.3f m without\n", max_step[1],
              max_step[0]);
  // A step moves the blend by at most 0.6 m / (2 m * band 3) = 0.1 on level 0 (less on coarser
  // levels), times the fine-to-coarse difference, which reaches ~10 m on this terrain's cliffs:
  // ~1 m. Measured on llvmpipe: 1.27 m with morphing, 25.2 m without.
  EXPECT_LT(max_step[1], 2.0);
  EXPECT_GT(max_step[0], 10.0 * max_step[1]);
}

// Moving in small steps uploads only strips, yet leaves every level's normal map equal to the
// CPU reference normal map of the decimated world (protocol/normal_map.h) and renders exactly
// what a renderer that uploaded everything for the final position renders.
TEST(ClipmapRender, ToroidalStripUploadsMatchAFreshFullUpload) {
  LOAM_REQUIRE_GL();
  const World& world = default_world();
  terrain::WorldHeightSource source(world);
  RendererConfig cfg;
  cfg.n = 63;
  cfg.levels = 5;
  cfg.detail_size = 256;  // the detail region moves toroidally too
  auto moving = ClipmapRenderer::create(source, cfg);
  ASSERT_TRUE(moving.ok());
  const int32_t w = 200, h = 150;
  auto target = OffscreenTarget::create(w, h);
  ASSERT_TRUE(target.ok());
  scene::Camera cam = scene::look_at(700, 900, 200, 1100, 500, 50);
  const int64_t full = (*moving)->update_levels(cam);
  EXPECT_EQ(full, int64_t(cfg.levels) * (63 + 2 * ClipmapRenderer::kLevelPad) *
                          (63 + 2 * ClipmapRenderer::kLevelPad) +
                      int64_t(cfg.detail_size) * cfg.detail_size);
  int64_t strips = 0, largest = 0;
  for (int i = 0; i < 40; ++i) {
    cam.x += 3.1, cam.y -= 1.7;
    const int64_t step = (*moving)->update_levels(cam);
    strips += step;
    largest = std::max(largest, step);
  }
  EXPECT_GT(strips, 0);
  EXPECT_LT(largest, full / 10) << "a 3.5 m step uploads only the strips that came into view";
  target->begin(0, 0, 0, 0);
  (*moving)->render(cam, w, h);
  const auto a = target->read_rgba();
  auto fresh = ClipmapRenderer::create(source, cfg);
  ASSERT_TRUE(fresh.ok());
  target->begin(0, 0, 0, 0);
  (*fresh)->render(cam, w, h);
  const auto b = target->read_rgba();
  // Both renderers' level normal maps are the reference normal map of the decimated world.
  for (int32_t l = 0; l < cfg.levels; ++l) {
    const RectI reg = (*fresh)->level_region(l);
    EXPECT_EQ((*moving)->level_region(l), reg);
    const RectI in{reg.x0 + 4, reg.y0 + 4, reg.x1 - 4, reg.y1 - 4};
    const auto want = generate_decimated_normal_map(world, l, in);
    for (ClipmapRenderer* r : {moving->get(), fresh->get()}) {
      const auto got = r->read_level_normals(l, in);
      size_t bad = 0;
      for (size_t i = 0; i < got.size(); ++i) bad += got[i] != want[i];
      EXPECT_EQ(bad, 0u) << "level " << l << (r == moving->get() ? " moving" : " fresh");
    }
  }
  size_t differ = 0;
  for (size_t i = 0; i < a.size(); i += 4)
    differ += !std::equal(a.begin() + ptrdiff_t(i), a.begin() + ptrdiff_t(i + 4), b.begin() + ptrdiff_t(i));
  EXPECT_EQ(differ, 0u) << "pixels differ between strip uploads and a fresh upload";
  if (differ != 0) {
    (void)write_png("toroidal_moving.png", w, h, a);
    (void)write_png("toroidal_fresh.png", w, h, b);
  }
}

// The same terrain 10,000 km from the origin (shifted by a multiple of 2^L tiles, east and
// north, so signed tile coordinates are crossed too) renders the same image bit for bit: only
// small integers and camera-relative offsets reach the GPU.
TEST(ClipmapRender, FarFromTheOriginTheSameTerrainRendersTheSameImage) {
  LOAM_REQUIRE_GL();
  const World& home = default_world();
  RendererConfig cfg;
  cfg.n = 63;
  cfg.view_distance = 3000;
  // Positions and heights are what this pins bit for bit. The shadow square and the material
  // textures' phases are computed in double from world positions, so far out they differ from
  // home in the last float bits (they stay within a texel: covered by the goldens).
  cfg.look.materials = false;
  cfg.look.shadows = false;
  const int32_t levels =
      lod::levels_for_view_distance(cfg.n, home.params().meters_per_sample, cfg.view_distance);
  const int32_t kx = 153 << levels, ky = -(153 << levels);  // tiles
  WorldParams far_params = home.params();
  far_params.origin_tile_x += kx;
  far_params.origin_tile_y += ky;
  std::vector<uint16_t> samples(size_t(home.params().sample_rect().area()));
  home.read_coarse(home.params().sample_rect(), samples);
  auto far = World::from_samples(far_params, samples);
  ASSERT_TRUE(far.ok());
  const double dx = double(kx) * kTileSize * home.params().meters_per_sample;
  const double dy = double(ky) * kTileSize * home.params().meters_per_sample;
  ASSERT_GT(std::hypot(dx, dy), 1.0e7);
  terrain::WorldHeightSource home_source(home), far_source(*far);
  auto home_r = ClipmapRenderer::create(home_source, cfg);
  auto far_r = ClipmapRenderer::create(far_source, cfg);
  ASSERT_TRUE(home_r.ok() && far_r.ok());
  auto target = OffscreenTarget::create(240, 160);
  ASSERT_TRUE(target.ok());
  struct View {
    double x, y, z, tx, ty, tz;
  };
  for (const View& v : {View{900.25, 1100.5, 160, 1200, 600, 20}, View{300, 300, 60, 900, 700, 0},
                        View{-200, 1800, 500, 1000, 700, 0}}) {
    target->begin(0, 0, 0, 0);
    (*home_r)->render(scene::look_at(v.x, v.y, v.z, v.tx, v.ty, v.tz), 240, 160);
    const auto a = target->read_rgba();
    const auto da = target->read_depth();
    target->begin(0, 0, 0, 0);
    (*far_r)->render(scene::look_at(v.x + dx, v.y + dy, v.z, v.tx + dx, v.ty + dy, v.tz), 240, 160);
    const auto b = target->read_rgba();
    EXPECT_TRUE(a == b) << "view from " << v.x << "," << v.y;
    EXPECT_TRUE(da == target->read_depth());
    size_t terrain = 0;
    for (size_t i = 3; i < a.size(); i += 4) terrain += a[i] != 0;
    EXPECT_GT(terrain, a.size() / 4 / 8) << "the view shows terrain";
  }
}

// Per-piece frustum culling drops pieces outside the view and changes no pixel.
TEST(ClipmapRender, CullingSkipsPiecesWithoutChangingTheImage) {
  LOAM_REQUIRE_GL();
  const World& world = default_world();
  terrain::WorldHeightSource source(world);
  auto target = OffscreenTarget::create(200, 120);
  ASSERT_TRUE(target.ok());
  scene::Camera cam = scene::look_at(600, 1200, height_at(world, 600, 1200) + 40, 1100, 800, 30);
  std::vector<uint8_t> images[2];
  FrameStats stats[2];
  for (int cull = 0; cull < 2; ++cull) {
    RendererConfig cfg;
    cfg.n = 63;
    cfg.cull = cull == 1;
    auto r = ClipmapRenderer::create(source, cfg);
    ASSERT_TRUE(r.ok());
    target->begin(0, 0, 0, 0);
    stats[cull] = (*r)->render(cam, 200, 120);
    images[cull] = target->read_rgba();
  }
  EXPECT_EQ(stats[0].pieces_culled, 0);
  EXPECT_GT(stats[1].pieces_culled, 0);
  EXPECT_LT(stats[1].triangles, stats[0].triangles);
  EXPECT_TRUE(images[0] == images[1]);
}

// The detail layer shows near the camera: footprints on it change the shading (normal
// mapping); with detail_displacement they move the finest level's geometry as well.
TEST(ClipmapRender, DetailLayerShowsInTheShadingAndOptionallyInTheGeometry) {
  LOAM_REQUIRE_GL();
  World plain = default_world();
  World printed = plain;
  const WorldParams& p = plain.params();
  for (int i = 0; i < 20; ++i) {
    StampParams f;
    f.kind = StampKind::kGaussian;
    f.layer = Layer::kDetail;
    f.center_x = 620 + 1.5 * i, f.center_y = 476 + (i % 2 ? 0.6 : -0.6);
    f.radius = 1.2, f.intensity = -0.5;
    auto q = validate_stamp(f, p);
    ASSERT_TRUE(q.ok()) << q.error().describe();
    ASSERT_TRUE(apply_stamp(printed, *q).ok());
  }
  printed.commit(1);
  auto target = OffscreenTarget::create(240, 160);
  ASSERT_TRUE(target.ok());
  const scene::Camera cam =
      scene::look_at(628, 486, height_at(plain, 628, 486) + 8, 634, 476, height_at(plain, 634, 476));
  auto draw = [&](const World& w, bool displace, std::vector<float>* depth) {
    terrain::WorldHeightSource source(w);
    RendererConfig cfg;
    cfg.n = 63;
    cfg.detail_displacement = displace;
    auto r = ClipmapRenderer::create(source, cfg);
    EXPECT_TRUE(r.ok());
    target->begin(0, 0, 0, 0);
    (*r)->render(cam, 240, 160);
    if (depth) *depth = target->read_depth();
    return target->read_rgba();
  };
  std::vector<float> d_plain, d_shaded, d_displaced;
  const auto plain_img = draw(plain, false, &d_plain);
  const auto shaded = draw(printed, false, &d_shaded);
  (void)draw(printed, true, &d_displaced);
  size_t pixels = 0;
  for (size_t i = 0; i < plain_img.size(); i += 4)
    pixels += plain_img[i] != shaded[i] || plain_img[i + 1] != shaded[i + 1];
  EXPECT_GT(pixels, 100u) << "the prints change the shading";
  EXPECT_TRUE(d_plain == d_shaded) << "without displacement the geometry is the coarse layer's";
  EXPECT_FALSE(d_plain == d_displaced) << "displacement moves the finest level's vertices";
}

}  // namespace
}  // namespace loam::render
