// Events at every mip (protocol/stamps/stamp_at_mip.h): a per-sample stamp evaluated on the
// samples of a mip-m tile gives exactly the decimation of the mip-0 result, for every kind and
// blend, at every mip, across tile corners and past the world's edges. This is what lets a
// client that holds only coarse mips follow a DeformEvent instead of receiving patches.
#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <vector>

#include "protocol/stamps/stamp_apply.h"
#include "protocol/stamps/stamp_at_mip.h"
#include "protocol/stamps/stamp_kernel.h"
#include "protocol/stamps/stamp_validate.h"
#include "protocol/world.h"
#include "tests/unit/stamps_test_util.h"

namespace loam {
namespace {

// 5 x 3 tiles from tile (-2, -1): mips 0..3, odd tile counts at every mip (so mip tiles reach
// past the world's edge), and a four-tile corner at sample (0, 0).
WorldParams odd_world() {
  WorldParams p;
  p.meters_per_sample = 1.0;
  p.meters_per_unit = 1.0 / 64.0;
  p.detail_factor = 4;
  p.origin_tile_x = -2;
  p.origin_tile_y = -1;
  p.tiles_x = 5;
  p.tiles_y = 3;
  return p;
}

// Rough terrain: a slope, ridges and hash noise, so every sample differs from its neighbours.
World rough_world(const WorldParams& p) {
  World w(p, 0);
  const RectI r = p.sample_rect();
  std::vector<uint16_t> samples(size_t(r.area()));
  size_t i = 0;
  for (int64_t y = r.y0; y < r.y1; ++y) {
    for (int64_t x = r.x0; x < r.x1; ++x) {
      uint64_t h = uint64_t(x * 73856093) ^ uint64_t(y * 19349663);
      h = (h ^ (h >> 13)) * 0x9E3779B97F4A7C15ull;
      const int64_t v = 30000 + 9 * x - 5 * y + int64_t((x * x + 3 * y) % 611) + int64_t(h >> 58);
      samples[i++] = uint16_t(std::clamp<int64_t>(v, 0, 65535));
    }
  }
  w.write_coarse(r, samples);
  w.commit(0);
  return w;
}

struct MipCase {
  std::string name;
  StampParams params;
};

using stamps_test::make_params;

std::vector<MipCase> cases(const WorldParams& p, uint64_t texture_id) {
  const RectI r = p.sample_rect();
  // Centers: the four-tile corner, a tile edge, a sub-sample offset, and the world's corners
  // and edges (stamps partly outside the world).
  const std::vector<std::pair<double, double>> centers = {
      {0.0, 0.0},
      {256.3, 17.7},
      {-100.25, 60.5},
      {double(r.x0) + 3.0, double(r.y0) + 2.0},
      {double(r.x1) - 1.5, double(r.y1) - 0.5},
      {double(r.x1) - 10.0, 0.0},
      {double(r.x0) + 0.2, double(r.y1) - 0.3},
  };
  std::vector<MipCase> out;
  int n = 0;
  for (const auto& [x, y] : centers) {
    const std::string at = " at (" + std::to_string(x) + ", " + std::to_string(y) + ")";
    const double radius = 9.0 + 13.0 * (n++ % 4);
    out.push_back({"gaussian add" + at, make_params(StampKind::kGaussian, x, y, radius, 3.5)});
    StampParams sub = make_params(StampKind::kGaussian, x, y, radius * 1.7, 2.0);
    sub.blend = BlendMode::kSubtract;
    out.push_back({"gaussian subtract" + at, sub});
    StampParams mn = make_params(StampKind::kGaussian, x, y, radius, -4.0);
    mn.blend = BlendMode::kMin;
    mn.target = 480.0;
    out.push_back({"gaussian min" + at, mn});
    StampParams mx = make_params(StampKind::kGaussian, x, y, radius, 4.0);
    mx.blend = BlendMode::kMax;
    mx.target = 470.0;
    out.push_back({"gaussian max" + at, mx});
    StampParams crater = make_params(StampKind::kCrater, x, y, radius, 6.0);
    crater.shape = 0.3;
    out.push_back({"crater" + at, crater});
    StampParams vc = crater;
    vc.volume_conserving = true;
    out.push_back({"volume-conserving crater" + at, vc});
    StampParams foot = make_params(StampKind::kFootprint, x, y, radius * 0.6, 1.5);
    foot.rotation = 0.7;
    out.push_back({"footprint" + at, foot});
    StampParams flat = make_params(StampKind::kFlatten, x, y, radius, 0.8);
    flat.target = 470.0;
    out.push_back({"flatten" + at, flat});
    StampParams tex = make_params(StampKind::kTexture, x, y, radius, 5.0);
    tex.rotation = 1.1;
    tex.texture_id = texture_id;
    out.push_back({"texture" + at, tex});
  }
  return out;
}

TEST(StampsEveryMip, PerSampleStampOnAMipTileEqualsDecimatingTheMip0Result) {
  const WorldParams p = odd_world();
  ASSERT_GE(p.mip_count(), 3);
  TextureRegistry textures;
  std::vector<uint16_t> img(7 * 5);
  for (size_t i = 0; i < img.size(); ++i) img[i] = uint16_t((i * 9173) % 65536);
  const uint64_t texture_id = textures.add(7, 5, img).value();
  const World before = rough_world(p);
  int mip_tiles_changed = 0, cases_run = 0;
  for (const MipCase& c : cases(p, texture_id)) {
    SCOPED_TRACE(c.name);
    auto q = validate_stamp(c.params, p, {}, &textures);
    ASSERT_TRUE(q.ok()) << q.error().describe();
    World after = before;
    ASSERT_TRUE(apply_stamp(after, *q, &textures).ok());
    const std::vector<TileChange> changes = after.commit(1);
    // The client's side: the stamp baked alone, the footprint's contact measured by the server.
    auto baked = bake_stamp(*q, p, &textures);
    ASSERT_TRUE(baked.ok());
    if (q->kind == StampKind::kFootprint) set_contact(*baked, footprint_contact_of(*baked, before));
    for (int32_t m = 0; m < p.mip_count(); ++m) {
      const RectI tiles = p.tile_range(m);
      for (int32_t ty = int32_t(tiles.y0); ty < tiles.y1; ++ty) {
        for (int32_t tx = int32_t(tiles.x0); tx < tiles.x1; ++tx) {
          const TileCoord tc{Layer::kCoarse, uint8_t(m), tx, ty};
          const std::span<const uint16_t> old = before.coarse_tile(m, tx, ty);
          std::vector<uint16_t> mine(old.begin(), old.end());
          const RectI rect = apply_to_coarse_tile(*baked, p, tc, mine);
          const std::span<const uint16_t> truth = after.coarse_tile(m, tx, ty);
          ASSERT_TRUE(std::equal(mine.begin(), mine.end(), truth.begin())) << to_string(tc);
          // The changed rect is the one the server's commit reports for the tile.
          RectI reported;
          for (const TileChange& ch : changes) {
            if (ch.coord == tc) reported = ch.rect;
          }
          EXPECT_EQ(rect, reported) << to_string(tc);
          if (m > 0 && !rect.empty()) ++mip_tiles_changed;
        }
      }
    }
    ++cases_run;
  }
  EXPECT_EQ(cases_run, 63);
  // The cases reach coarse mips (they would pass vacuously otherwise).
  EXPECT_GT(mip_tiles_changed, 100);
}

TEST(StampsEveryMip, FootprintWithTheServersContactNeedsNoSamplesUnderTheFoot) {
  // A client that holds only the mip-0 tile on one side of the corner: the samples under the
  // rest of the foot are unknown (zero) to it, yet with the contact from the event its tile
  // comes out exactly as the server's.
  const WorldParams p = odd_world();
  const World server_before = rough_world(p);
  auto q = validate_stamp(make_params(StampKind::kFootprint, 2.0, 3.0, 30.0, 2.0), p);
  ASSERT_TRUE(q.ok());
  auto baked = bake_stamp(*q, p);
  ASSERT_TRUE(baked.ok());
  const FootprintContact contact = footprint_contact_of(*baked, server_before);
  ASSERT_TRUE(contact.touches);
  World server = server_before;
  ASSERT_TRUE(apply_stamp(server, *q).ok());
  server.commit(1);

  World client(p, 0);
  const std::span<const uint16_t> held = server_before.coarse_tile(0, 0, 0);
  client.write_coarse(tile_rect(0, 0), held);
  client.commit(0);
  World guessed = client;
  ASSERT_TRUE(apply_stamp(guessed, *q).ok());  // contact measured on what it holds: wrong
  ASSERT_TRUE(apply_stamp_with_contact(client, *q, contact).ok());
  const auto truth = server.coarse_tile(0, 0, 0);
  const auto mine = client.coarse_tile(0, 0, 0);
  EXPECT_TRUE(std::equal(mine.begin(), mine.end(), truth.begin()));
  const auto wrong = guessed.coarse_tile(0, 0, 0);
  EXPECT_FALSE(std::equal(wrong.begin(), wrong.end(), truth.begin()));
}

TEST(StampsEveryMip, MipSamplesReachingIncludeEverySampleBeyondTheEdgeTheRectTouches) {
  const WorldParams p = odd_world();  // samples x in [-512, 768), y in [-256, 512)
  // Mip 1: the mip tile range is 3 x 2 tiles, samples [-256, 512) x [-256, 256).
  EXPECT_EQ(mip_samples_reaching(p, 1, RectI{10, 10, 14, 13}), (RectI{5, 5, 7, 7}));
  EXPECT_EQ(mip_samples_reaching(p, 1, RectI{11, 11, 12, 12}), RectI{});  // no even sample
  EXPECT_EQ(mip_samples_reaching(p, 1, RectI{760, 500, 768, 512}), (RectI{380, 250, 512, 256}));
  EXPECT_EQ(mip_samples_reaching(p, 2, RectI{-512, -256, -500, -250}), (RectI{-256, -256, -125, -62}));
}

}  // namespace
}  // namespace loam
