// The geomipmap, quadtree and error-driven clipmap renderers (client/render/
// geomipmap_renderer.h, quadtree_renderer.h, error_clipmap_renderer.h) draw what their CPU
// replicas (client/lod/) say: a straight-down
// orthographic view with one pixel per sample reads back, at every sample, the replica's
// displayed height (levels or subdivision, and morphs, chosen from another, perspective
// camera), with no hole; after a stamp, the same holds with the error bounds of exactly the
// touched patches recomputed.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <type_traits>

#include "bench/lod/geomipmap_renderer.h"
#include "bench/lod/quadtree_renderer.h"
#include "client/lod/projected_error.h"
#include "client/render/error_clipmap_renderer.h"
#include "client/render/offscreen_target.h"
#include "gl_test_context.h"
#include "protocol/normal_map.h"
#include "protocol/world.h"

namespace loam::render {
namespace {

// A world of tiles_x x tiles_y tiles at 2 m, its heights height(x, y) (units), committed.
World sampled_world(int32_t tiles_x, int32_t tiles_y, const std::function<double(int64_t, int64_t)>& height) {
  WorldParams p;
  p.tiles_x = tiles_x;
  p.tiles_y = tiles_y;
  p.meters_per_sample = 2.0;
  p.meters_per_unit = 0.05;
  const RectI r = p.sample_rect();
  std::vector<uint16_t> s(size_t(r.area()));
  for (int64_t y = 0; y < r.height(); ++y)
    for (int64_t x = 0; x < r.width(); ++x) s[size_t(y * r.width() + x)] = uint16_t(height(x, y));
  World w = std::move(World::from_samples(p, s).value());
  w.commit(0);
  return w;
}

World ridges() {
  return sampled_world(1, 1, [](int64_t x, int64_t y) {
    return 20000 + 3000 * std::sin(double(x) * 0.07) * std::cos(double(y) * 0.05) +
           (x > 150 && x < 156 ? 4000 : 0) + double((x * 7 + y * 13) % 5);
  });
}

// Writes a cone-shaped crater over [100, 131) x [60, 91) and commits it; returns the rect.
RectI dig_crater(World& w) {
  const RectI crater{100, 60, 131, 91};
  std::vector<uint16_t> s(size_t(crater.area()));
  for (int64_t y = crater.y0; y < crater.y1; ++y)
    for (int64_t x = crater.x0; x < crater.x1; ++x)
      s[size_t((y - crater.y0) * crater.width() + (x - crater.x0))] =
          uint16_t(15000 + 300 * std::hypot(double(x) - 115, double(y) - 75));
  w.write_coarse(crater, s);
  w.commit(1);
  return crater;
}

// Heights (m above the height offset) the renderer drew at every sample, from a top-down
// orthographic view with pixel centres on the samples; NaN where nothing was drawn.
template <typename Renderer>
std::vector<double> drawn_heights(Renderer& r, const OffscreenTarget& t, const scene::Camera& lod_camera) {
  const double mps = 2.0;
  scene::Camera cam;
  cam.x = (t.width() / 2.0 - 0.5) * mps, cam.y = (t.height() / 2.0 - 0.5) * mps, cam.z = 3000;
  cam.fx = 0, cam.fy = 0, cam.fz = -1;
  cam.ux = 0, cam.uy = -1, cam.uz = 0;
  cam.ortho_half_height = t.height() / 2.0 * mps;
  cam.near_m = 1, cam.far_m = 4000;
  t.begin(0, 0, 0, 0);
  r.select(lod_camera, t.height());
  r.draw(cam, t.width(), t.height());
  const auto depth = t.read_depth();
  std::vector<double> out(depth.size());
  for (size_t i = 0; i < depth.size(); ++i) {
    out[i] = depth[i] <= scene::kBackgroundDepth ? NAN : cam.z - scene::view_distance(cam, depth[i]);
  }
  return out;
}

// Largest |drawn - replica| (m) over the samples, and the samples with nothing drawn (the
// world's outer rows and columns aside). `border_cells` > 0: samples on the borders of patches
// that many cells wide are left out (with skirts two patches draw a border at two heights).
template <typename Renderer>
std::pair<double, int64_t> compare_with_replica(Renderer& r, const OffscreenTarget& t, const World& w,
                                                const scene::Camera& lod_camera, int32_t border_cells = 0) {
  const auto drawn = drawn_heights(r, t, lod_camera);
  const RectI rect = w.params().sample_rect();
  std::vector<uint16_t> samples(size_t(rect.area()));
  w.read_coarse(rect, samples);
  const lod::HeightGrid grid{samples, rect.width(), rect.height()};
  std::vector<float> surface;
  int64_t cw = 0;
  if constexpr (std::is_same_v<Renderer, GeomipmapRenderer>) {
    surface = lod::displayed_surface(r.grid(), grid, r.lods());
    cw = r.grid().covered().width();
  } else if constexpr (std::is_same_v<Renderer, ErrorClipmapRenderer>) {
    surface = lod::displayed_surface(r.grid(), grid, r.selection());
    cw = r.selection().covered.width();
  } else {
    surface = lod::displayed_surface(r.grid(), grid, r.state());
    cw = r.grid().covered().width();
  }
  double worst = 0;
  int64_t holes = 0;
  for (int64_t y = 0; y < rect.height(); ++y) {
    for (int64_t x = 0; x < rect.width(); ++x) {
      const double d = drawn[size_t(y * rect.width() + x)];
      if (std::isnan(d)) {
        // The world's first and last rows and columns lie exactly on the mesh's outer edge (the
        // error-driven clipmap draws vertices past the world at its last sample), which the
        // fill rule may leave.
        holes += x > 0 && y > 0 && x + 1 < rect.width() && y + 1 < rect.height();
        continue;
      }
      if (border_cells > 0 && (x % border_cells == 0 || y % border_cells == 0)) continue;
      const double want = double(surface[size_t(y * cw + x)]) * w.params().meters_per_unit;
      worst = std::max(worst, std::abs(d - want));
    }
  }
  return {worst, holes};
}

scene::Camera perspective_at(double x, double y, double z, double tx, double ty) {
  scene::Camera c = scene::look_at(x, y, z, tx, ty, 900);
  c.fov_y_degrees = 60;
  return c;
}

TEST(GeomipmapRender, TheDrawnSurfaceIsTheReplicasAtEverySample) {
  LOAM_REQUIRE_GL();
  World w = ridges();
  terrain::WorldHeightSource source(w);
  auto target = OffscreenTarget::create(256, 256);
  ASSERT_TRUE(target.ok());
  for (int32_t n : {9, 17, 33, -17}) {
    // -17: tiled blocks with skirts, whose vertical skirts leave the top-down view as it is.
    GeomipmapConfig cfg;
    cfg.patch_size = std::abs(n);
    cfg.skirts = n < 0;
    cfg.tolerance_px = 2.0;
    cfg.cull = false;
    auto r = GeomipmapRenderer::create(source, cfg);
    ASSERT_TRUE(r.ok()) << r.error().describe();
    for (const scene::Camera& lc :
         {perspective_at(-100, -100, 1400, 256, 256), perspective_at(256, 256, 1100, 500, 100)}) {
      const auto [worst, holes] =
          compare_with_replica(**r, *target, w, lc, cfg.skirts ? cfg.patch_size - 1 : 0);
      int levels = 0, morphing = 0;
      for (const lod::PatchLod& p : (*r)->lods()) levels |= 1 << p.level, morphing += p.morph > 0;
      std::printf("patch %d: levels mask %x, %d patches morphing, largest difference %.4f m, %lld holes\n", n,
                  levels, morphing, worst, static_cast<long long>(holes));
      EXPECT_GT(__builtin_popcount(unsigned(levels)), 1) << "the view mixes levels";
      EXPECT_GT(morphing, 0);
      EXPECT_EQ(holes, 0);
      EXPECT_LT(worst, 0.02);
    }
  }
}

TEST(GeomipmapRender, AStampReuploadsItsRectAndRecomputesTheTouchedPatchesOnly) {
  LOAM_REQUIRE_GL();
  World w = ridges();
  terrain::WorldHeightSource source(w);
  auto target = OffscreenTarget::create(256, 256);
  ASSERT_TRUE(target.ok());
  GeomipmapConfig cfg;
  cfg.cull = false;
  auto r = GeomipmapRenderer::create(source, cfg);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  // A crater [100, 131) x [60, 91): patches 6..8 by 3..5 of 17.
  const RectI crater = dig_crater(w);
  const GeomipmapUpdate u = (*r)->invalidate(crater);
  EXPECT_EQ(u.patches, 9);
  const scene::Camera lc = perspective_at(230, 150, 1000, 100, 60);
  const auto [worst, holes] = compare_with_replica(**r, *target, w, lc);
  EXPECT_EQ(holes, 0);
  EXPECT_LT(worst, 0.02);
  // The renderer's error bounds are those of the stamped world.
  const RectI rect = w.params().sample_rect();
  std::vector<uint16_t> samples(size_t(rect.area()));
  w.read_coarse(rect, samples);
  const auto fresh = lod::GeomipmapErrors::compute((*r)->grid(), {samples, rect.width(), rect.height()});
  for (int32_t py = 0; py < (*r)->grid().patches_y; ++py)
    for (int32_t px = 0; px < (*r)->grid().patches_x; ++px)
      for (int32_t l = 0; l < (*r)->grid().levels; ++l)
        EXPECT_EQ((*r)->errors().error(px, py, l), fresh.error(px, py, l));
}

TEST(QuadtreeRender, TheDrawnSurfaceIsTheReplicasAtEverySampleBeforeAndAfterAStamp) {
  LOAM_REQUIRE_GL();
  World w = ridges();
  terrain::WorldHeightSource source(w);
  auto target = OffscreenTarget::create(256, 256);
  ASSERT_TRUE(target.ok());
  for (int32_t block : {16, 64, -32}) {
    // -32: tiled blocks with skirts.
    QuadtreeConfig cfg;
    cfg.block_size = std::abs(block);
    cfg.skirts = block < 0;
    cfg.tolerance_px = 2.0;
    cfg.cull = false;
    auto r = QuadtreeRenderer::create(source, cfg);
    ASSERT_TRUE(r.ok()) << r.error().describe();
    for (const scene::Camera& lc :
         {perspective_at(-100, -100, 1400, 256, 256), perspective_at(256, 256, 1100, 500, 100)}) {
      const auto [worst, holes] = compare_with_replica(**r, *target, w, lc, cfg.skirts ? cfg.block_size : 0);
      std::printf("block %d: largest difference %.4f m, %lld holes\n", block, worst,
                  static_cast<long long>(holes));
      EXPECT_EQ(holes, 0);
      EXPECT_LT(worst, 0.02);
    }
  }
  // A crater: the squares holding it are recomputed and their blocks rebuilt.
  QuadtreeConfig cfg;
  cfg.cull = false;
  auto r = QuadtreeRenderer::create(source, cfg);
  ASSERT_TRUE(r.ok());
  const scene::Camera lc = perspective_at(230, 150, 1000, 100, 60);
  (void)compare_with_replica(**r, *target, w, lc);
  const RectI crater = dig_crater(w);
  EXPECT_GT((*r)->invalidate(crater), 0);
  const auto [worst, holes] = compare_with_replica(**r, *target, w, lc);
  EXPECT_EQ(holes, 0);
  EXPECT_LT(worst, 0.02);
}

TEST(ErrorClipmapRender, TheDrawnSurfaceIsTheReplicasAtEverySampleBeforeAndAfterAStamp) {
  LOAM_REQUIRE_GL();
  World w = ridges();
  terrain::WorldHeightSource source(w);
  auto target = OffscreenTarget::create(256, 256);
  ASSERT_TRUE(target.ok());
  for (int32_t block : {9, 17}) {
    ErrorClipmapConfig cfg;
    cfg.block_size = block;
    cfg.region =
        16 * (block - 1);  // level 0 holds at most a quarter of the world: regions limit the finest blocks
    cfg.levels = 5;
    cfg.tolerance_px = 1.0;
    cfg.cull = false;
    auto r = ErrorClipmapRenderer::create(source, cfg);
    ASSERT_TRUE(r.ok()) << r.error().describe();
    for (const scene::Camera& lc :
         {perspective_at(-100, -100, 900, 256, 256), perspective_at(256, 256, 300, 500, 100)}) {
      const auto [worst, holes] = compare_with_replica(**r, *target, w, lc);
      int levels = 0, morphing = 0;
      for (const lod::ClipmapBlock& b : (*r)->selection().blocks)
        levels |= 1 << b.id.level, morphing += b.lod.morph > 0;
      std::printf(
          "block %d: %d levels, levels mask %x, %d blocks morphing, largest difference %.4f m, %lld holes\n",
          block, (*r)->levels(), levels, morphing, worst, static_cast<long long>(holes));
      EXPECT_GE(__builtin_popcount(unsigned(levels)), 2) << "the view mixes levels";
      EXPECT_GT(morphing, 0);
      EXPECT_EQ((*r)->selection().stats.unrestricted, 0);
      EXPECT_EQ(holes, 0);
      EXPECT_LT(worst, 0.02);
    }
  }
  // A crater: every level region holding it re-reads it, and exactly the blocks holding it get
  // new error bounds.
  ErrorClipmapConfig cfg;
  cfg.block_size = 17;
  cfg.cull = false;
  cfg.region = 256;
  cfg.levels = 5;
  auto r = ErrorClipmapRenderer::create(source, cfg);
  ASSERT_TRUE(r.ok());
  const scene::Camera lc = perspective_at(230, 150, 400, 100, 60);
  (void)compare_with_replica(**r, *target, w, lc);
  const RectI crater = dig_crater(w);
  const ErrorClipmapUpdate u = (*r)->invalidate(crater);
  // [100, 131) x [60, 91), blocks of 16 << l samples sharing borders: 3 x 3 at level 0, 2 x 2
  // at 1 and 2 (its rows 0..64 and 64..128), 2 x 1 at 3, 1 at 4.
  EXPECT_EQ(u.blocks, 9 + 4 + 4 + 2 + 1);
  EXPECT_GT(u.texels, 31 * 31);
  const auto [worst, holes] = compare_with_replica(**r, *target, w, lc);
  EXPECT_EQ(holes, 0);
  EXPECT_LT(worst, 0.02);
  const auto fresh = lod::ClipmapErrorPyramid::compute(
      (*r)->grid(),
      [&](int32_t l, const RectI& rect, std::span<uint16_t> out) { (*r)->read_level(l, rect, out); },
      cfg.exact_levels);
  const lod::ClipmapBlockGrid& g = (*r)->grid();
  for (int32_t l = 0; l < g.levels; ++l)
    for (int32_t by = 0; by < g.blocks_y(l); ++by)
      for (int32_t bx = 0; bx < g.blocks_x(l); ++bx)
        EXPECT_EQ((*r)->errors().error(l, bx, by), fresh.error(l, bx, by));
}

// Every level's normals, where blocks may be drawn, are the world's FD4 normal map at that
// level's spacing bit for bit: after the first placement, after the regions slide (strips and
// the rims that became drawable), and after a stamp; for the tori and for the levels held
// whole side by side in a shared layer alike.
TEST(ErrorClipmapRender, LevelNormalsAreTheWorldsNormalMapAfterSlidesAndAStamp) {
  LOAM_REQUIRE_GL();
  World w = ridges();
  terrain::WorldHeightSource source(w);
  ErrorClipmapConfig cfg;
  cfg.block_size = 9;
  cfg.region = 128;  // half the world: regions with rims inside it
  cfg.levels = 4;
  auto r = ErrorClipmapRenderer::create(source, cfg);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  // Levels 0 and 1 (257 and 129 samples a side) are tori of 128; 2 and 3 (65 and 33) share one.
  EXPECT_EQ((*r)->layers(), 3);
  const RectI world = w.params().sample_rect();
  auto check = [&](const char* when) {
    for (int32_t l = 0; l < (*r)->levels(); ++l) {
      const int64_t s = int64_t(1) << l;
      // The region less 4 samples everywhere (inside what may be drawn), within the world.
      const RectI reg = (*r)->region(l);
      const RectI in = RectI{reg.x0 + 4, reg.y0 + 4, reg.x1 - 4, reg.y1 - 4}.intersect(
          {0, 0, (world.width() - 1) / s + 1, (world.height() - 1) / s + 1});
      ASSERT_FALSE(in.empty());
      const RectI global{in.x0 + world.x0 / s, in.y0 + world.y0 / s, in.x1 + world.x0 / s,
                         in.y1 + world.y0 / s};
      const auto want = generate_decimated_normal_map(w, l, global);
      const auto got = (*r)->read_level_normals(l, in);
      size_t bad = 0;
      for (size_t i = 0; i < got.size(); ++i) bad += got[i] != want[i];
      EXPECT_EQ(bad, 0u) << when << ", level " << l;
    }
  };
  (*r)->select(perspective_at(60, 60, 500, 200, 200), 256);
  check("placed");
  (*r)->select(perspective_at(90, 75, 500, 200, 200), 256);
  (*r)->select(perspective_at(150, 140, 500, 20, 20), 256);
  check("slid");
  const RectI crater = dig_crater(w);
  (*r)->invalidate(crater);
  check("stamped");
}
// Where every level's region holds all the world, no split the budget asks for is held back and
// the renderer's windowed error bounds choose exactly what the whole-world pyramid does: in a
// world whose block counts halve to an odd number (768 samples across: 3 blocks at level 5, 2
// roots at 6), the roots' children reach past the last blocks, and a level held whole holds
// them too.
TEST(ErrorClipmapRender, WithRegionsHoldingTheWorldTheSelectionIsTheWholeWorldPyramids) {
  LOAM_REQUIRE_GL();
  const World w = sampled_world(3, 1, [](int64_t x, int64_t y) {
    return 20000 + 3000 * std::sin(double(x) * 0.031) * std::cos(double(y) * 0.047) +
           double((x * 7 + y * 13) % 23);
  });
  const WorldParams& p = w.params();
  terrain::WorldHeightSource source(w);
  ErrorClipmapConfig cfg;
  cfg.levels = 7;
  cfg.cull = false;
  cfg.look.materials = cfg.look.shadows = false;
  auto r = ErrorClipmapRenderer::create(source, cfg);
  ASSERT_TRUE(r.ok()) << r.error().describe();
  const lod::ClipmapBlockGrid& g = (*r)->grid();
  ASSERT_EQ(g.blocks_x(5), 3);
  ASSERT_EQ(g.blocks_x(6), 2);
  const auto full = lod::ClipmapErrorPyramid::compute(
      g, [&](int32_t l, const RectI& rect, std::span<uint16_t> out) { (*r)->read_level(l, rect, out); },
      cfg.exact_levels);
  for (const scene::Camera& cam :
       {perspective_at(-100, -100, 900, 700, 300), perspective_at(1300, 200, 1000, 100, 400)}) {
    (*r)->select(cam, 256, 256);
    std::vector<RectI> regions;
    for (int32_t l = 0; l < g.levels; ++l) regions.push_back((*r)->region(l));
    lod::LodView view;
    view.x = cam.x, view.y = cam.y, view.z = cam.z;
    view.pixels_per_radian = lod::pixels_per_radian(256, cam.fov_y_degrees);
    view.tolerance_px = cfg.tolerance_px;
    lod::set_view_axes(view, {cam.fx, cam.fy, cam.fz}, {cam.ux, cam.uy, cam.uz}, cam.fov_y_degrees, 1.0);
    const lod::ErrorClipmapSelection want = lod::select_error_clipmap(
        g, full, {p.meters_per_sample, p.meters_per_unit, p.height_offset}, view, regions, cfg.morph);
    const lod::ErrorClipmapSelection& got = (*r)->selection();
    // The regions hold the world: no split the budget asks for is held back for want of one.
    EXPECT_EQ(got.stats.held_back, 0);
    ASSERT_EQ(got.blocks.size(), want.blocks.size());
    for (size_t i = 0; i < got.blocks.size(); ++i) ASSERT_EQ(got.blocks[i].id, want.blocks[i].id) << i;
    std::printf("%zu blocks (%lld splits held back), %d layers for %d levels\n", got.blocks.size(),
                static_cast<long long>(got.stats.held_back), (*r)->layers(), (*r)->levels());
  }
}
}  // namespace
}  // namespace loam::render
