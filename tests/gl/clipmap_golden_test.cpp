// Golden images: a few views of the embedded terrain, one of them deformed (craters on the
// coarse layer, a trail of footprints on the detail layer near the camera), rendered headless
// and compared with the committed PNGs in tests/golden/images/ by OpenImageIO's idiff. The
// threshold: fail when more than 1% of pixels differ by more than 2/255, or any pixel by more
// than half the range. On failure the rendered image and an absolute difference image (x10)
// are left in golden-out/ beside the test binary's working folder. scripts/approve-goldens.sh
// re-renders and replaces the goldens (LOAM_APPROVE_GOLDENS=<folder> makes this test write
// them there instead of comparing).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <span>
#include <string>

#include "client/controls/walker.h"
#include "client/query/snapshot_builder.h"
#include "client/render/clipmap_renderer.h"
#include "client/render/offscreen_target.h"
#include "dem/default_terrain.h"
#include "dem/refined_default.h"
#include "gl_test_context.h"
#include "golden_image.h"
#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/surface.h"

namespace loam::render {
namespace {

constexpr int32_t kWidth = 320, kHeight = 180;

// Camera and target positions in world meters; heights are above the ground under them.
struct GoldenView {
  const char* name;
  double x, y, dz, tx, ty, tdz;
  bool deformed;
};

const GoldenView kViews[] = {
    {"overview", -250, 1850, 600, 1000, 700, 0, false},          // the whole world, its edge skirt
    {"sea_floor_grazing", 560, 1180, 12, 1100, 900, 10, false},  // grazing, over the sea floor
    {"plateau_cliffs", 1500, 300, 120, 700, 700, 0, false},      // 80-degree cliffs, snow
    {"deformed_close", 650, 498, 16, 620, 474, 0, true},         // craters and a trail of prints
};

// The embedded terrain (the Tarim basin, near the deformed view) with three craters and a
// trail of footprints on the detail layer.
World deformed(World w) {
  const WorldParams& p = w.params();
  auto stamp = [&](StampParams s) {
    auto q = validate_stamp(s, p);
    ASSERT_TRUE(q.ok()) << q.error().describe();
    ASSERT_TRUE(apply_stamp(w, *q).ok());
  };
  for (int i = 0; i < 3; ++i) {
    StampParams c;
    c.kind = StampKind::kCrater;
    c.center_x = 600 + 14 * i, c.center_y = 470 - 5 * i, c.radius = 3 + 1.5 * i, c.intensity = 1.0 + 0.4 * i;
    c.shape = 0.35;
    stamp(c);
  }
  for (int i = 0; i < 14; ++i) {
    StampParams f;
    f.kind = StampKind::kGaussian;
    f.layer = Layer::kDetail;
    f.center_x = 622 + 2.0 * i, f.center_y = 482 - 1.0 * i + (i % 2 ? 0.7 : -0.7);
    f.radius = 1.0, f.intensity = -0.25;
    stamp(f);
  }
  w.commit(1);
  return w;
}

// Renders `cam` of `source` into `target` and compares it with the golden `name`.png, or writes
// it to LOAM_APPROVE_GOLDENS.
void render_and_compare_one(OffscreenTarget& target, const terrain::HeightSource& source,
                            const scene::Camera& cam, const std::string& name,
                            const RendererConfig& cfg = {}) {  // the defaults users get
  auto renderer = ClipmapRenderer::create(source, cfg);
  ASSERT_TRUE(renderer.ok());
  target.begin(0.50f, 0.60f, 0.75f, 0.0f);
  (*renderer)->render(cam, kWidth, kHeight);
  test::compare_with_golden(name, kWidth, kHeight, target.read_rgba());
}

// Renders each view (of `dented` where the view says so) and compares it with its golden.
void render_and_compare(std::span<const GoldenView> views, const World& plain, const World& dented) {
  LOAM_REQUIRE_IDIFF();
  auto target = OffscreenTarget::create(kWidth, kHeight);
  ASSERT_TRUE(target.ok());
  for (const GoldenView& v : views) {
    const World& w = v.deformed ? dented : plain;
    terrain::WorldHeightSource source(w,
                                      v.deformed ? &plain : nullptr);  // dug ground against the plain terrain
    scene::Camera cam =
        scene::look_at(v.x, v.y, height_at(w, v.x, v.y) + v.dz, v.tx, v.ty, height_at(w, v.tx, v.ty) + v.tdz);
    cam.far_m = 8000;
    render_and_compare_one(*target, source, cam, v.name);
  }
}

// The walk mode's view: a walker standing in the Tarim basin, a crater dug under it; it falls
// to the floor, and its eye looks across the crater at the wall.
TEST(ClipmapGolden, AWalkersViewFromTheFloorOfACraterDugUnderIt) {
  LOAM_REQUIRE_GL();
  LOAM_REQUIRE_IDIFF();
  auto imported = load_default_terrain();
  ASSERT_TRUE(imported.ok());
  World w = std::move(imported->world);
  const std::vector<TileCoord> held = [&] {
    std::vector<TileCoord> out;
    const RectI t = w.params().tile_range(0);
    for (int64_t ty = t.y0; ty < t.y1; ++ty) {
      for (int64_t tx = t.x0; tx < t.x1; ++tx) out.push_back({Layer::kCoarse, 0, int32_t(tx), int32_t(ty)});
    }
    return out;
  }();
  query::SnapshotBuilder snapshots(w.params());
  auto s = snapshots.build(w, held, {}, 0, 0);
  controls::Walker walker = controls::place_walker(*s, 640, 486);
  ASSERT_TRUE(walker.grounded) << "ground normal z " << walker.ground_normal.z << " at " << walker.feet.z;
  const double before = walker.feet.z;
  StampParams crater;
  crater.kind = StampKind::kCrater;
  crater.center_x = walker.feet.x, crater.center_y = walker.feet.y;
  crater.radius = 10, crater.intensity = 2.5, crater.shape = 0.3;
  auto q = validate_stamp(crater, w.params());
  ASSERT_TRUE(q.ok()) << q.error().describe();
  const World undug = w;
  ASSERT_TRUE(apply_stamp(w, *q).ok());
  w.commit(1);
  s = snapshots.build(w, held, std::vector<query::ChangedRect>{{Layer::kCoarse, w.params().sample_rect()}}, 1,
                      0);
  for (int i = 0; i < 180; ++i) controls::step_walker(walker, *s, {}, 1.0 / 60);
  ASSERT_TRUE(walker.grounded);
  EXPECT_LT(walker.feet.z, before - 1.5);
  const glm::dvec3 eye = controls::walker_eye(walker);
  const double yaw = 0.6;
  scene::Camera cam = scene::look_at(eye.x, eye.y, eye.z, eye.x + 10 * std::cos(yaw),
                                     eye.y + 10 * std::sin(yaw), eye.z - 0.8);
  cam.fov_y_degrees = 70;
  cam.near_m = 0.1;
  cam.far_m = 8000;
  auto target = OffscreenTarget::create(kWidth, kHeight);
  ASSERT_TRUE(target.ok());
  terrain::WorldHeightSource source(w, &undug);
  render_and_compare_one(*target, source, cam, "walker_in_crater");
}

TEST(ClipmapGolden, ViewsOfTheEmbeddedTerrainMatchTheirGoldens) {
  LOAM_REQUIRE_GL();
  auto imported = load_default_terrain();
  ASSERT_TRUE(imported.ok());
  const World plain = std::move(imported->world);
  const World dented = deformed(plain);
  render_and_compare(kViews, plain, dented);
}

// The refined default world (131 x 98 km at 1 m, generated on demand): views at the scales
// a player meets it, from a ridge line to the metre texture of a slope, and craters dug at 1 m.
const GoldenView kRefinedViews[] = {
    {"refined_himalaya", 59000, 34500, 400, 59000, 29500, 0, false},     // the Himalayan front, 5 km
    {"refined_slope_close", 60200, 30150, 25, 60120, 30020, 0, false},   // a slope at 1 m, grazing
    {"refined_bay_coast", 52400, 62000, 150, 52400, 58000, 0, false},    // coast and sea floor
    {"refined_deformed_close", 60140, 30050, 9, 60122, 30024, 0, true},  // three craters, 25 m away
};

TEST(ClipmapGolden, ViewsOfTheRefinedDefaultMatchTheirGoldens) {
  LOAM_REQUIRE_GL();
  auto base = refined_default_base();
  ASSERT_TRUE(base.ok()) << base.error().describe();
  const World plain(refined_default_params(), *base);
  World dented = plain;
  {
    const WorldParams& p = dented.params();
    for (int i = 0; i < 3; ++i) {
      StampParams c;
      c.kind = StampKind::kCrater;
      c.center_x = 60118 + 9 * i, c.center_y = 30030 - 6 * i, c.radius = 2 + 1.2 * i,
      c.intensity = 0.8 + 0.3 * i;
      c.shape = 0.35;
      auto q = validate_stamp(c, p);
      ASSERT_TRUE(q.ok()) << q.error().describe();
      ASSERT_TRUE(apply_stamp(dented, *q).ok());
    }
    dented.commit(1);
  }
  render_and_compare(kRefinedViews, plain, dented);
}

}  // namespace
}  // namespace loam::render
