// End-to-end tests of the viewer stack: a real loam-server process on loopback, headless
// viewers (client/render/viewer_session.h) rendering through EGL on llvmpipe, and bots. They
// pin that a viewer's own stamps show before the server answers and settle without
// corrections, that events stamped on the GPU tile cache match the confirmed store texel for
// texel, and that two viewers converge on the server's hashes and render identical images.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <thread>

#include "client/render/offscreen_target.h"
#include "client/render/viewer_session.h"
#include "gl/gl_test_context.h"
#include "integration/integration_util.h"
#include "integration/server_process.h"
#include "protocol/normal_map.h"

namespace loam::test {
namespace {

using namespace std::chrono_literals;

render::ViewerOptions small_viewer(const std::string& name) {
  render::ViewerOptions o;
  o.name = name;
  o.renderer.n = 63;
  o.renderer.view_distance = 2500;
  o.interest.mip0_radius_m = 300;
  o.interest.detail_radius_m = 40;
  return o;
}

scene::Camera overview() {
  scene::Camera c = scene::look_at(900, 1300, 420, 1000, 700, 40);
  c.far_m = 6000;
  return c;
}

QuantizedStamp crater_at(const WorldParams& w, double x, double y, double r, double depth) {
  StampParams p;
  p.kind = StampKind::kCrater;
  p.center_x = x;
  p.center_y = y;
  p.radius = r;
  p.intensity = depth;
  p.shape = 0.3;
  auto q = validate_stamp(p, w);
  EXPECT_TRUE(q.ok());
  return *q;
}

// The coarse samples of `r` the viewer's display shows, and those its confirmed store holds.
std::vector<uint16_t> shown_samples(render::ViewerSession& v, const RectI& r) {
  std::vector<uint16_t> out(size_t(r.area()));
  v.display().world().read_coarse(r, out);
  return out;
}
std::vector<uint16_t> confirmed_samples(render::ViewerSession& v, const RectI& r) {
  std::vector<uint16_t> out(size_t(r.area()));
  v.client().store().mirror().read_coarse(r, out);
  return out;
}

// The display's GPU copy holds its CPU copy in every resident tile (each read back whole), and
// every level texture holds what the level's CPU read gives: no change the GPU path took was
// lost or taken differently.
void expect_gpu_terrain_matches(render::ViewerSession& v) {
  const uint64_t audited = v.display().counters().gpu_tiles_audited;
  EXPECT_EQ(v.display().audit_gpu(SIZE_MAX), 0u);
  EXPECT_GT(v.display().counters().gpu_tiles_audited, audited) << "no tile is resident";
  render::ErrorClipmapRenderer* r = v.error_clipmap();
  ASSERT_NE(r, nullptr);
  for (int32_t l = 0; l < r->levels(); ++l) {
    const RectI region = r->region(l);
    if (region.empty()) continue;
    std::vector<uint16_t> cpu(size_t(region.area()));
    r->read_level(l, region, cpu);
    EXPECT_EQ(r->read_level_heights(l, region), cpu) << "level " << l;
  }
}

// An own crater and a bot's, near the camera (in the viewer's mip-0 tiles, held within 300 m of
// the eye at (900, 1300) m: four tiles of the coarse layer), `n` times, the
// viewer's frames going meanwhile (updates and renders); returns the last global sequence
// stamped, once the viewer saw it and settled.
uint64_t stamp_near_the_camera(render::ViewerSession& view, client::TerrainClient& bot,
                               const scene::Camera& cam, int n, uint32_t seed) {
  auto target = render::OffscreenTarget::create(160, 100);
  EXPECT_TRUE(target.ok());
  auto frame = [&] {
    target->begin(0.5f, 0.6f, 0.75f, 0.0f);
    view.render(cam, 160, 100);
  };
  frame();  // the levels' regions are placed
  std::mt19937 rng(seed);
  const WorldParams& w = bot.welcome().world;
  std::uniform_real_distribution<double> ux(750, 1150), uy(960, 1450), ur(6, 30);
  std::vector<uint32_t> seqs;
  for (int i = 0; i < n; ++i) {
    auto s = bot.deform(crater_at(w, ux(rng), uy(rng), ur(rng), 2));
    EXPECT_TRUE(s.ok());
    if (s.ok()) seqs.push_back(*s);
    if (i % 3 == 0) {
      EXPECT_TRUE(view.deform(crater_at(w, ux(rng), uy(rng), ur(rng), 3)).ok());
    }
    EXPECT_TRUE(view.update(cam, 5ms).ok());
    frame();
    EXPECT_TRUE(bot.pump(0ms).ok());
  }
  EXPECT_TRUE(bot.wait_until([&] { return bot.ack(seqs.back()).has_value(); }, 30s));
  EXPECT_TRUE(view.wait_settled(cam, 30s));
  const uint64_t last = std::max(bot.ack(seqs.back())->global_seq, view.client().last_seen_seq());
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (view.client().last_event_seq() < last && std::chrono::steady_clock::now() < deadline) {
    EXPECT_TRUE(view.update(cam, 5ms).ok());
  }
  EXPECT_GE(view.client().last_event_seq(), last);
  EXPECT_TRUE(view.wait_settled(cam, 30s));
  frame();
  return last;
}

std::vector<uint8_t> render_view(render::ViewerSession& v, const scene::Camera& cam, int32_t w, int32_t h) {
  auto target = render::OffscreenTarget::create(w, h);
  EXPECT_TRUE(target.ok());
  target->begin(0.5f, 0.6f, 0.75f, 0.0f);
  v.render(cam, w, h);
  return target->read_rgba();
}

// Both --lod schemes: the default (error) and the classic.
class ViewerOfEitherScheme : public ::testing::TestWithParam<render::LodScheme> {};

TEST_P(ViewerOfEitherScheme, OwnStampShowsBeforeTheServerAnswersAndSettlesWithoutCorrections) {
  LOAM_REQUIRE_GL();
  const std::string dir = temp_data_dir("own");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--hashes-every", "10"})) << server.log();
  const scene::Camera cam = overview();
  render::ViewerOptions options = small_viewer("viewer");
  options.lod = GetParam();
  auto v = render::ViewerSession::connect("127.0.0.1", server.port(), options, cam);
  ASSERT_TRUE(v.ok()) << v.error().describe();
  render::ViewerSession& view = **v;
  ASSERT_TRUE(view.wait_settled(cam, 30s));
  const auto before = render_view(view, cam, 160, 100);

  const WorldParams& w = view.client().welcome().world;
  const QuantizedStamp q = crater_at(w, 1000, 760, 40, 6);
  ASSERT_TRUE(view.deform(q).ok());
  // Nothing pumped yet: the server cannot have answered, the display already shows the crater.
  EXPECT_EQ(view.display().overlay_size(), 1u);
  (void)view.display().sync(view.client());
  const RectI r{475, 355, 525, 405};  // the crater's middle, samples
  EXPECT_NE(shown_samples(view, r), confirmed_samples(view, r)) << "the overlay did not change the display";
  view.invalidate(r);
  EXPECT_NE(render_view(view, cam, 160, 100), before) << "the crater does not show in the render";

  ASSERT_TRUE(view.wait_settled(cam, 30s));
  EXPECT_EQ(shown_samples(view, r), confirmed_samples(view, r));
  const terrain::DisplayCounters& k = view.display().counters();
  EXPECT_EQ(k.predicted, 1u);
  EXPECT_EQ(k.retired, 1u);
  EXPECT_EQ(k.corrections, 0u);
  EXPECT_EQ(k.divergent_texels, 0u);
  EXPECT_TRUE(view.display().on_gpu());
}

INSTANTIATE_TEST_SUITE_P(ViewerEndToEnd, ViewerOfEitherScheme,
                         ::testing::Values(render::LodScheme::kError, render::LodScheme::kClassic),
                         [](const ::testing::TestParamInfo<render::LodScheme>& p) {
                           return std::string(render::to_string(p.param));
                         });

// A session on an imported DEM: the client cannot generate its initial terrain, so the dug
// layer measures against what the store kept of each tile's version 0. An own crater reads as
// dug as soon as it shows (its tiles still at version 0) and still once the server confirmed
// it (the kept copies); ground away from it reads as unchanged.
// GPU stamping (the display's tile cache) with the default renderer: confirmed events and own
// stamps reach the level textures GPU to GPU. Nothing is read back, the GPU copy and every level
// equal their CPU counterparts afterwards, and the change layer (dug earth) moved with the
// heights as the CPU computes it.
TEST(ViewerEndToEnd, GpuStampedChangesFillTheLevelsOnTheGpuAndNothingIsReadBack) {
  LOAM_REQUIRE_GL();
  const std::string dir = temp_data_dir("gpu_levels");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--tick-hz", "60", "--hashes-every", "10"})) << server.log();
  const scene::Camera cam = overview();
  render::ViewerOptions o = small_viewer("viewer");
  o.error_clipmap.region = 256;
  o.gpu_audit_tiles = 0;  // the sampled check reads back; this test wants to see nothing else does
  auto v = render::ViewerSession::connect("127.0.0.1", server.port(), o, cam);
  ASSERT_TRUE(v.ok()) << v.error().describe();
  render::ViewerSession& view = **v;
  ASSERT_TRUE(view.display().on_gpu());
  client::TerrainClient bot;
  ASSERT_TRUE(bot.connect("127.0.0.1", server.port(), "bot", wire::Role::kBot).ok());
  ASSERT_TRUE(bot.subscribe(bot.all_coarse_tiles(0)).ok());
  ASSERT_TRUE(view.wait_settled(cam, 30s));
  const render::ViewerStats before = view.stats();

  const uint64_t last = stamp_near_the_camera(view, bot, cam, 30, 11);
  const render::ViewerStats s = view.stats();
  EXPECT_GT(s.display.events_stamped, 0u);
  EXPECT_GT(s.display.predicted, 0u);
  EXPECT_GT(s.level_traffic.texels_on_gpu, 0u);
  EXPECT_EQ(s.display_traffic.bytes_read_back, 0u);
  const uint64_t changes = s.display.events_stamped + s.display.predicted;
  const uint64_t fills = s.display_traffic.page_fills - before.display_traffic.page_fills;
  std::printf(
      "%llu stamps on the GPU copy: %.0f B of constants each, %llu pages filled; levels: %llu samples filled "
      "on the GPU (%.0f B uploaded each change), %llu uploaded\n",
      (unsigned long long)changes,
      double(s.display_traffic.bytes_uploaded - before.display_traffic.bytes_uploaded - fills * 131072) /
          double(changes),
      (unsigned long long)fills, (unsigned long long)s.level_traffic.texels_on_gpu,
      double(s.level_traffic.bytes_uploaded - before.level_traffic.bytes_uploaded) / double(changes),
      (unsigned long long)(s.level_traffic.texels_uploaded - before.level_traffic.texels_uploaded));
  expect_gpu_terrain_matches(view);
  EXPECT_TRUE(store_matches(view.client(), replayed_world(dir, last)));

  // The level normals the GPU recomputed after each stamp are the reference normal map of the
  // display's samples, bit for bit, over the held tiles the stamps fell on (the stencils reach
  // 2 level samples, 4 at the world's edges: a margin of 16 mip-0 samples up to level 3).
  render::ErrorClipmapRenderer& r = *view.error_clipmap();
  for (int32_t l = 0; l < 4; ++l) {
    const int64_t m = int64_t(1) << l;
    const RectI held{272, 272, 752, 752};  // mip-0 samples, inside tiles 1-2 x 1-2
    const RectI in = RectI{ceil_div(held.x0, m), ceil_div(held.y0, m), held.x1 / m, held.y1 / m}.intersect(
        RectI{r.region(l).x0 + 4, r.region(l).y0 + 4, r.region(l).x1 - 4, r.region(l).y1 - 4});
    if (in.empty()) continue;
    for (int64_t ty = 1; ty <= 2; ++ty)
      for (int64_t tx = 1; tx <= 2; ++tx)
        ASSERT_TRUE(view.client().store().holds({Layer::kCoarse, 0, int32_t(tx), int32_t(ty)}));
    const auto want = generate_decimated_normal_map(view.display().world(), l, in);
    const auto got = r.read_level_normals(l, in);
    ASSERT_EQ(got.size(), want.size());
    size_t bad = 0;
    for (size_t i = 0; i < got.size(); ++i) bad += got[i] != want[i];
    EXPECT_EQ(bad, 0u) << "level " << l;
  }

  // The change layers: what the CPU computes from the heights, to their half-float precision.
  const RectI world = view.client().welcome().world.sample_rect();
  ASSERT_EQ(world.x0 % 1024, 0);  // every level reads its mip, change layer included
  ASSERT_EQ(world.y0 % 1024, 0);
  size_t dug = 0, off = 0;
  for (int32_t l = 0; l < std::min(r.levels(), 10); ++l) {
    const int64_t step = int64_t(1) << l;
    const RectI inside =
        r.region(l).intersect({0, 0, (world.width() - 1) / step + 1, (world.height() - 1) / step + 1});
    if (inside.empty()) continue;
    std::vector<float> cpu(size_t(inside.area()));
    ASSERT_TRUE(view.display().read_change(l, inside.translated(world.x0 / step, world.y0 / step), cpu));
    const std::vector<float> gpu = r.read_level_change(l, inside);
    ASSERT_EQ(gpu.size(), cpu.size());
    for (size_t i = 0; i < cpu.size(); ++i) {
      dug += cpu[i] < -0.01f;
      off += std::abs(gpu[i] - cpu[i]) > std::max(1e-3f, std::abs(cpu[i]) / 1024.0f);
    }
  }
  EXPECT_GT(dug, 0u) << "no dug ground in view";
  EXPECT_EQ(off, 0u) << "change samples that differ from the CPU's";
}

// A GPU tile cache of two pages: stamps reach more tiles than it holds, so pages are evicted and
// filled again from the CPU copy, and stamps wider than the cache go up from the CPU copy. The
// GPU copy and the levels still equal the CPU's, and the store the server's log.
TEST(ViewerEndToEnd, ASmallGpuTileCacheEvictsRefillsAndStillMatchesTheStore) {
  LOAM_REQUIRE_GL();
  const std::string dir = temp_data_dir("small_cache");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--tick-hz", "60", "--hashes-every", "10"})) << server.log();
  const scene::Camera cam = overview();
  render::ViewerOptions o = small_viewer("viewer");
  o.error_clipmap.region = 256;
  o.gpu_cache_pages = 2;
  auto v = render::ViewerSession::connect("127.0.0.1", server.port(), o, cam);
  ASSERT_TRUE(v.ok()) << v.error().describe();
  render::ViewerSession& view = **v;
  client::TerrainClient bot;
  ASSERT_TRUE(bot.connect("127.0.0.1", server.port(), "bot", wire::Role::kBot).ok());
  ASSERT_TRUE(bot.subscribe(bot.all_coarse_tiles(0)).ok());
  ASSERT_TRUE(view.wait_settled(cam, 30s));

  const uint64_t last = stamp_near_the_camera(view, bot, cam, 40, 12);
  const terrain::DisplayMemory m = view.display().memory();
  EXPECT_GT(m.gpu.evictions, 0u);
  EXPECT_LE(m.gpu.resident_pages[Layer::kCoarse], 2);
  expect_gpu_terrain_matches(view);
  EXPECT_TRUE(store_matches(view.client(), replayed_world(dir, last)));
  EXPECT_EQ(view.display().counters().corrections, 0u);
}

// Own stamps the server refuses (over its rate limit) were shown at once; each is undone on both
// copies from the store (the CPU copy's rect copied back and uploaded), so the GPU copy, the
// levels and the display equal the confirmed state again.
TEST(ViewerEndToEnd, RefusedOwnStampsAreUndoneOnTheGpuCopyFromTheStore) {
  LOAM_REQUIRE_GL();
  const std::string dir = temp_data_dir("refused");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--deforms-per-second", "1", "--deform-burst", "1"})) << server.log();
  const scene::Camera cam = overview();
  render::ViewerOptions o = small_viewer("viewer");
  o.error_clipmap.region = 256;
  auto v = render::ViewerSession::connect("127.0.0.1", server.port(), o, cam);
  ASSERT_TRUE(v.ok()) << v.error().describe();
  render::ViewerSession& view = **v;
  ASSERT_TRUE(view.wait_settled(cam, 30s));
  const WorldParams& w = view.client().welcome().world;
  for (int i = 0; i < 6; ++i) ASSERT_TRUE(view.deform(crater_at(w, 900 + 40 * i, 760, 20, 6)).ok());
  EXPECT_EQ(view.display().overlay_size(), 6u);
  ASSERT_TRUE(view.wait_settled(cam, 30s));
  const terrain::DisplayCounters& k = view.display().counters();
  EXPECT_GT(k.rejected, 0u);
  EXPECT_LT(k.rejected, 6u);
  const RectI r{400, 330, 640, 430};  // every crater's reach, samples
  EXPECT_EQ(shown_samples(view, r), confirmed_samples(view, r));
  expect_gpu_terrain_matches(view);
}

TEST(ViewerEndToEnd, ErrorDrivenClipmapViewerHoldsItsRegionsTilesAndShowsAStampOnceSettled) {
  LOAM_REQUIRE_GL();
  const std::string dir = temp_data_dir("error_lod");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--hashes-every", "10"})) << server.log();
  const scene::Camera cam = overview();
  render::ViewerOptions o = small_viewer("viewer");
  o.lod = render::LodScheme::kError;
  o.error_clipmap.region = 256;
  auto v = render::ViewerSession::connect("127.0.0.1", server.port(), o, cam);
  ASSERT_TRUE(v.ok()) << v.error().describe();
  render::ViewerSession& view = **v;
  ASSERT_EQ(view.lod(), render::LodScheme::kError);
  ASSERT_EQ(view.classic(), nullptr);
  ASSERT_TRUE(view.wait_settled(cam, 30s));
  const auto before = render_view(view, cam, 160, 100);
  // Every level's region is held at the level's own mip: the interest followed the error-driven
  // clipmap's regions, not the classic clipmap's rings.
  const render::LevelCoverage cov = view.coverage();
  EXPECT_EQ(cov.levels, view.levels());
  EXPECT_EQ(cov.levels_lacking, 0);
  int64_t terrain_pixels = 0;  // alpha 1: terrain (the clear's is 0)
  for (size_t i = 3; i < before.size(); i += 4) terrain_pixels += before[i] != 0;
  EXPECT_GT(terrain_pixels, 160 * 100 / 4) << "the error-driven clipmap drew no terrain";

  const QuantizedStamp q = crater_at(view.client().welcome().world, 1000, 760, 40, 6);
  ASSERT_TRUE(view.deform(q).ok());
  ASSERT_TRUE(view.wait_settled(cam, 30s));
  const RectI r{475, 355, 525, 405};  // the crater's middle, samples
  EXPECT_EQ(shown_samples(view, r), confirmed_samples(view, r));
  EXPECT_NE(render_view(view, cam, 160, 100), before) << "the crater does not show in the render";
  EXPECT_EQ(view.stats().hash_mismatches, 0u);
}

TEST(ViewerEndToEnd, OnAnImportedDemACraterDugInViewReadsAsDug) {
  LOAM_REQUIRE_GL();
  const std::string dir = temp_data_dir("imported_dug");
  const std::string png = default_terrain_png(dir);
  ASSERT_FALSE(::testing::Test::HasFailure());
  ServerProcess server;
  ASSERT_TRUE(server.start(dir + "/data", {"--dem", png})) << server.log();
  const scene::Camera cam = overview();
  auto v = render::ViewerSession::connect("127.0.0.1", server.port(), small_viewer("viewer"), cam);
  ASSERT_TRUE(v.ok()) << v.error().describe();
  render::ViewerSession& view = **v;
  ASSERT_EQ(view.client().shared_base(), nullptr) << "the test needs a base the client cannot generate";
  ASSERT_TRUE(view.wait_settled(cam, 30s));

  const WorldParams& w = view.client().welcome().world;
  const double cx = 1000 / w.meters_per_sample, cy = 760 / w.meters_per_sample;  // samples
  const QuantizedStamp q = crater_at(w, 1000, 760, 40, 6);
  const RectI middle{int64_t(cx) - 4, int64_t(cy) - 4, int64_t(cx) + 4, int64_t(cy) + 4};
  const RectI away{int64_t(cx) + 120, int64_t(cy) - 4, int64_t(cx) + 128, int64_t(cy) + 4};
  const auto deepest = [&](const RectI& r) {
    std::vector<float> change(size_t(r.area()));
    EXPECT_TRUE(view.display().read_change(0, r, change));
    return *std::min_element(change.begin(), change.end());
  };
  EXPECT_EQ(deepest(middle), 0.0f);
  ASSERT_TRUE(view.deform(q).ok());
  (void)view.display().sync(view.client());
  EXPECT_LT(deepest(middle), -3.0f) << "the predicted crater does not read as dug";

  ASSERT_TRUE(view.wait_settled(cam, 30s));
  const auto v0 =
      view.client().store().version({Layer::kCoarse, 0, int32_t(cx / kTileSize), int32_t(cy / kTileSize)});
  ASSERT_TRUE(v0.has_value());
  EXPECT_GT(*v0, 0u);
  EXPECT_GE(view.client().store().initial_tiles_kept(), 1u);
  EXPECT_LT(deepest(middle), -3.0f) << "the confirmed crater does not read as dug";
  EXPECT_EQ(deepest(away), 0.0f);
  EXPECT_EQ(server.terminate(), 0) << server.log();
}

// The viewer predicts a stamp on the terrain it holds while a bot's raise at the same spot,
// unseen by the viewer, is sequenced first, and the viewer learns of both in one sync. A
// flatten does not commute with the raise: the confirmed result differs from the prediction
// and the difference is counted as corrections. A second raise commutes: no correction, though
// the same samples changed (the raise is accounted for as another client's event).
TEST(ViewerEndToEnd, PredictionOverAnotherStampSequencedFirstCountsCorrectionsOnlyWhenTheyDoNotCommute) {
  LOAM_REQUIRE_GL();
  const std::string dir = temp_data_dir("order");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir)) << server.log();
  const scene::Camera cam = overview();
  auto v = render::ViewerSession::connect("127.0.0.1", server.port(), small_viewer("viewer"), cam);
  ASSERT_TRUE(v.ok()) << v.error().describe();
  render::ViewerSession& view = **v;
  ASSERT_TRUE(view.wait_settled(cam, 30s));
  client::TerrainClient bot;
  ASSERT_TRUE(bot.connect("127.0.0.1", server.port(), "bot", wire::Role::kBot).ok());
  const WorldParams& w = bot.welcome().world;
  client::TerrainClient& c = view.client();

  auto scenario = [&](StampKind kind, double x) -> uint64_t {
    const uint64_t before = view.display().counters().corrections;
    StampParams raise;
    raise.kind = StampKind::kGaussian;
    raise.center_x = x, raise.center_y = 760, raise.radius = 30, raise.intensity = 8;
    auto sb = bot.deform(*validate_stamp(raise, w));
    EXPECT_TRUE(sb.ok());
    EXPECT_TRUE(bot.wait_until([&] { return bot.ack(*sb).has_value(); }, 30s));
    // The viewer has not read anything since: it predicts on the terrain without the raise.
    StampParams mine;
    mine.kind = kind;
    mine.center_x = x, mine.center_y = 760, mine.radius = 25, mine.intensity = 0.8;
    if (kind == StampKind::kFlatten) mine.target = 40;
    if (kind == StampKind::kGaussian) mine.intensity = 3;
    auto sa = view.deform(*validate_stamp(mine, w));
    EXPECT_TRUE(sa.ok());
    // The store takes in both events before the display looks again.
    EXPECT_TRUE(
        c.wait_until([&] { return c.ack(*sa) && c.last_event_seq() >= c.ack(*sa)->global_seq; }, 30s));
    EXPECT_EQ(c.ack(*sa)->global_seq, bot.ack(*sb)->global_seq + 1);
    (void)view.display().sync(c);
    EXPECT_TRUE(view.wait_settled(cam, 30s));
    const RectI r{int64_t(x / 2) - 60, 320, int64_t(x / 2) + 60, 440};
    EXPECT_EQ(shown_samples(view, r), confirmed_samples(view, r));
    return view.display().counters().corrections - before;
  };
  const uint64_t flatten = scenario(StampKind::kFlatten, 1000);
  const uint64_t add = scenario(StampKind::kGaussian, 1200);
  std::printf("corrections: flatten after a raise %llu texels, raise after a raise %llu\n",
              (unsigned long long)flatten, (unsigned long long)add);
  EXPECT_GT(flatten, 0u) << "a flatten after a raise is not a raise after a flatten";
  EXPECT_EQ(add, 0u);
  EXPECT_EQ(view.display().counters().retired, 2u);
}

// The server dies (kill -9) right after the viewer sent a stamp, with another waiting on its
// side (the server allows one unacknowledged Deform), and comes back from its data folder: the
// viewer reconnects; the stamp that had left is answered as lost and leaves the overlay (the
// server may or may not have made it durable: the confirmed state says which), the one that
// never left goes to the new server and settles by its event; the viewer converges on the
// recovered server's tiles with no divergence.
TEST(ViewerEndToEnd, ViewerReconnectsAfterTheServerRestartsAndConverges) {
  LOAM_REQUIRE_GL();
  const std::string dir = temp_data_dir("restart");
  const std::vector<std::string> args = {"--hashes-every", "5", "--max-pending-deforms", "1"};
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, args)) << server.log();
  const scene::Camera cam = overview();
  auto v = render::ViewerSession::connect("127.0.0.1", server.port(), small_viewer("viewer"), cam);
  ASSERT_TRUE(v.ok()) << v.error().describe();
  render::ViewerSession& view = **v;
  ASSERT_TRUE(view.wait_settled(cam, 30s));
  const WorldParams& w = view.client().welcome().world;
  ASSERT_TRUE(view.deform(crater_at(w, 980, 740, 20, 4)).ok());
  ASSERT_TRUE(view.wait_settled(cam, 30s));
  // The first answered and a pacer interval (1/60 s) past: the next stamp leaves at once.
  ASSERT_TRUE(view.client().wait_until([&] { return view.client().deforms_unacked() == 0; }, 30s));
  std::this_thread::sleep_for(50ms);
  const auto sent = view.deform(crater_at(w, 1040, 780, 15, 3));
  const auto waiting = view.deform(crater_at(w, 1000, 700, 10, 2));
  ASSERT_TRUE(sent.ok() && waiting.ok());
  ASSERT_EQ(view.client().deforms_queued(), 1u) << "the second waits for the first's answer";
  server.kill9();
  // The loss shows as an error from update (the inbox drains first).
  Status st;
  for (int i = 0; i < 200 && st.ok(); ++i) st = view.update(cam, 10ms);
  ASSERT_FALSE(st.ok());
  // Still waiting unless the first's ack beat the kill (the 30 Hz tick makes that unlikely but
  // possible): then the second left too, and may be lost or answered like the first.
  const bool never_left = view.client().deforms_queued() == 1;
  ASSERT_TRUE(server.start(dir, args)) << server.log();
  ASSERT_TRUE(view.reconnect("127.0.0.1", server.port()).ok());
  const uint64_t welcomed = view.client().welcome().global_sequence;
  ASSERT_TRUE(view.wait_settled(cam, 30s));
  EXPECT_EQ(view.display().overlay_size(), 0u);
  // All three settled: the first by its event, each other one by its answer: accepted, or lost
  // with the connection (which is what the display counts as abandoned).
  EXPECT_EQ(view.display().counters().retired, 3u);
  uint64_t lost = 0, last_seq = welcomed;
  for (const uint32_t s : {*sent, *waiting}) {
    const auto a = view.client().ack(s);
    ASSERT_TRUE(a.has_value()) << "stamp " << s << " has no answer";
    EXPECT_TRUE(a->lost || a->accepted) << a->field;
    lost += a->lost;
    if (a->accepted) last_seq = std::max(last_seq, a->global_seq);
  }
  EXPECT_EQ(view.display().counters().abandoned, lost);
  if (never_left) {
    const auto later = view.client().ack(*waiting);
    EXPECT_TRUE(later->accepted && !later->lost) << later->field;
    EXPECT_EQ(later->global_seq, welcomed + 1) << "sequenced by the restarted server";
  }
  // Let a TileHashes round compare everything held.
  const size_t hashes = view.client().tile_hash_messages();
  ASSERT_TRUE(view.client().wait_until([&] { return view.client().tile_hash_messages() > hashes + 1; }, 30s));
  EXPECT_EQ(view.client().hash_mismatches(), 0u);
  const World expected = replayed_world(dir, last_seq);
  EXPECT_TRUE(store_matches(view.client(), expected));
  // The resumed session's regions may reach the store after the first wait_settled (the tiles
  // held from before the restart count as held) and while the client alone was pumped above:
  // the display follows the store at its next update.
  ASSERT_TRUE(view.wait_settled(cam, 30s));
  const RectI r{440, 320, 560, 440};
  EXPECT_EQ(shown_samples(view, r), confirmed_samples(view, r));
  EXPECT_EQ(view.display().counters().divergent_texels, 0u);
}

TEST(ViewerEndToEnd, TwoViewersAndABotConvergeOnTheServersHashesAndRenderTheSameView) {
  LOAM_REQUIRE_GL();
  const std::string dir = temp_data_dir("two");
  ServerProcess server;
  ASSERT_TRUE(server.start(dir, {"--tick-hz", "60", "--hashes-every", "10"})) << server.log();
  const scene::Camera cam = overview();
  // This world's initial terrain is not one a client generates, so each viewer's dug layer
  // follows what it held when the ground changed (docs/rendering.md): the images compare the
  // terrain, its light and shadows, without materials.
  render::ViewerOptions oa = small_viewer("viewer-a"), ob = small_viewer("viewer-b");
  oa.renderer.look.materials = ob.renderer.look.materials = false;
  auto a = render::ViewerSession::connect("127.0.0.1", server.port(), oa, cam);
  ASSERT_TRUE(a.ok()) << a.error().describe();
  auto b = render::ViewerSession::connect("127.0.0.1", server.port(), ob, cam);
  ASSERT_TRUE(b.ok()) << b.error().describe();
  client::TerrainClient bot;
  ASSERT_TRUE(bot.connect("127.0.0.1", server.port(), "bot", wire::Role::kBot).ok());
  ASSERT_TRUE(bot.subscribe(bot.all_coarse_tiles(0)).ok());

  // The bot and viewer A deform (A's own stamps near the camera, so they are predicted);
  // every viewer keeps its frames going meanwhile.
  std::mt19937 rng(7);
  StampRng stamps(7);
  const WorldParams& w = bot.welcome().world;
  std::vector<uint32_t> bot_seqs;
  std::uniform_real_distribution<double> ux(800, 1200), uy(600, 900), ur(6, 30);
  for (int i = 0; i < 40; ++i) {
    auto s = bot.deform(random_stamp(stamps, w));
    ASSERT_TRUE(s.ok());
    bot_seqs.push_back(*s);
    if (i % 4 == 0) {
      ASSERT_TRUE((*a)->deform(crater_at(w, ux(rng), uy(rng), ur(rng), 2)).ok());
    }
    ASSERT_TRUE((*a)->update(cam, 5ms).ok());
    ASSERT_TRUE((*b)->update(cam, 0ms).ok());
    ASSERT_TRUE(bot.pump(0ms).ok());
  }
  ASSERT_TRUE(bot.wait_until([&] { return bot.ack(bot_seqs.back()).has_value(); }, 30s));
  ASSERT_TRUE((*a)->wait_settled(cam, 30s));
  ASSERT_TRUE((*b)->wait_settled(cam, 30s));
  uint64_t last = bot.ack(bot_seqs.back())->global_seq;
  last = std::max(last, (*a)->client().last_seen_seq());
  // Let both viewers see every event up to the last one.
  for (auto* v : {a->get(), b->get()}) {
    ASSERT_TRUE(v->client().wait_until([&] { return v->client().last_event_seq() >= last; }, 30s));
    ASSERT_TRUE(v->wait_settled(cam, 30s));
  }
  const World expected = replayed_world(dir, last);
  EXPECT_TRUE(store_matches((*a)->client(), expected));
  EXPECT_TRUE(store_matches((*b)->client(), expected));
  for (auto* v : {a->get(), b->get()}) {
    const terrain::DisplayCounters& k = v->display().counters();
    EXPECT_EQ(k.divergent_texels, 0u);
    EXPECT_GT(k.events_stamped, 0u);
    expect_gpu_terrain_matches(*v);
    EXPECT_EQ(v->display().overlay_size(), 0u);
    std::printf(
        "%s: %llu events stamped on the GPU, %llu followed by copying, %llu predicted, %llu corrections\n",
        v->client().welcome().client_id == (*a)->client().welcome().client_id ? "viewer a" : "viewer b",
        (unsigned long long)k.events_stamped, (unsigned long long)k.events_copied,
        (unsigned long long)k.predicted, (unsigned long long)k.corrections);
  }
  EXPECT_GT((*a)->display().counters().predicted, 0u);
  // Same view, same confirmed tiles: the same image, byte for byte.
  EXPECT_EQ(render_view(**a, cam, 200, 120), render_view(**b, cam, 200, 120));
}

}  // namespace
}  // namespace loam::test
