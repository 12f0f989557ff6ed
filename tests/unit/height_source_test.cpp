// What a clipmap level reads past the world's edge (client/terrain/height_source.h): a client
// holding coarse mip tiles alone reads exactly what the whole world gives there, so a live
// view and a render of the same state from a snapshot draw the same picture; and an edit
// reaching a level's edge sample is known to change the samples past that edge.
#include "client/terrain/height_source.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "client/net/confirmed_store.h"
#include "client/terrain/display_terrain.h"

namespace loam::terrain {
namespace {

// A rough world: every sample random, so a read of the wrong sample cannot go unseen.
World rough_world(const WorldParams& p, uint32_t seed) {
  World w(p, 0);
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> h(0, 65535);
  const RectI r = p.sample_rect();
  std::vector<uint16_t> samples(size_t(r.area()));
  for (uint16_t& s : samples) s = uint16_t(h(rng));
  w.write_coarse(r, samples);
  w.commit(1);
  return w;
}

WorldParams params(int32_t origin_x, int32_t origin_y, int32_t tiles_x, int32_t tiles_y) {
  return WorldParams{.meters_per_sample = 2.0,
                     .origin_tile_x = origin_x,
                     .origin_tile_y = origin_y,
                     .tiles_x = tiles_x,
                     .tiles_y = tiles_y};
}

// A level's read rect reaching well past every edge of the world at `mip`.
RectI past_every_edge(const WorldParams& p, int32_t mip) {
  const RectI w = p.sample_rect();
  const int64_t s = int64_t(1) << mip;
  return {floor_div(w.x0, s) - 9, floor_div(w.y0, s) - 7, ceil_div(w.x1, s) + 11, ceil_div(w.y1, s) + 6};
}

TEST(HeightSource, ACoarseTileHolderReadsWhatTheWorldReadsPastEveryEdge) {
  // Worlds whose edges fall on a mip's tile boundary (the mip holds no sample past the edge)
  // and worlds whose edges do not, at origins off zero.
  for (const WorldParams& p : {params(0, 0, 4, 3), params(-1, 1, 3, 2), params(2, -3, 5, 1)}) {
    const World world = rough_world(p, uint32_t(p.tiles_x * 7 + p.tiles_y));
    const WorldHeightSource whole(world);
    const int32_t mips = p.mip_count();
    for (int32_t held = 1; held < mips; ++held) {
      client::ConfirmedStore store(p);
      const RectI tiles = p.tile_range(held);
      for (int64_t ty = tiles.y0; ty < tiles.y1; ++ty) {
        for (int64_t tx = tiles.x0; tx < tiles.x1; ++tx) {
          const TileCoord c{Layer::kCoarse, uint8_t(held), int32_t(tx), int32_t(ty)};
          store.want(c);
          ASSERT_TRUE(store.replace<CoarseLayer>(c, 1, world.coarse_tile(held, c.tx, c.ty)).ok());
        }
      }
      auto display = DisplayTerrain::create(store, {});
      ASSERT_TRUE(display.ok());
      // Every level from the held mip up, past the coarsest mip too.
      for (int32_t mip = held; mip < mips + 3; ++mip) {
        const RectI r = past_every_edge(p, mip);
        std::vector<uint16_t> want(size_t(r.area())), got(size_t(r.area()));
        whole.read(mip, r, want);
        (*display)->read(mip, r, got);
        ASSERT_EQ(got, want) << "world " << p.tiles_x << "x" << p.tiles_y << " at " << p.origin_tile_x << ","
                             << p.origin_tile_y << ", mip-" << held << " tiles held, level mip " << mip;
      }
    }
  }
}

TEST(HeightSource, PastAnEdgeALevelRepeatsItsOwnEdgeSample) {
  const WorldParams p = params(0, 0, 4, 3);  // samples [0, 1024) x [0, 768)
  const World world = rough_world(p, 3);
  const WorldHeightSource source(world);
  for (int32_t mip = 0; mip < 6; ++mip) {
    const int64_t s = int64_t(1) << mip;
    const int64_t last_x = (1023 / s) * s, last_y = (767 / s) * s;
    std::vector<uint16_t> out(4);
    source.read(mip, {1023 / s + 1, 767 / s + 1, 1023 / s + 3, 767 / s + 3}, out);
    for (uint16_t v : out) EXPECT_EQ(v, world.coarse(last_x, last_y)) << "mip " << mip;
    source.read(mip, {-2, -2, 0, 0}, out);
    for (uint16_t v : out) EXPECT_EQ(v, world.coarse(0, 0)) << "mip " << mip;
  }
}

TEST(HeightSource, AnEditReachesEveryLevelSampleThatReadsIt) {
  for (const WorldParams& p : {params(0, 0, 4, 3), params(-1, 1, 3, 2)}) {
    const RectI w = p.sample_rect();
    std::mt19937 rng(11);
    for (int32_t mip = 0; mip < 12; ++mip) {
      const LevelAxis ax(mip, w.x0, w.x1), ay(mip, w.y0, w.y1);
      const int64_t s = int64_t(1) << mip;
      for (int trial = 0; trial < 40; ++trial) {
        std::uniform_int_distribution<int64_t> px(w.x0 - 40, w.x1 + 40), py(w.y0 - 40, w.y1 + 40);
        std::uniform_int_distribution<int64_t> size(1, 3 * s + 2);
        const int64_t x0 = px(rng), y0 = py(rng);
        const RectI edit{x0, y0, x0 + size(rng), y0 + size(rng)};
        const RectI reach = level_samples_reading(p, mip, edit);
        // Brute force over the level's samples around the world, well past its edges.
        const RectI around{floor_div(w.x0, s) - 20, floor_div(w.y0, s) - 20, ceil_div(w.x1, s) + 20,
                           ceil_div(w.y1, s) + 20};
        for (int64_t y = around.y0; y < around.y1; ++y) {
          for (int64_t x = around.x0; x < around.x1; ++x) {
            const bool reads = edit.contains(ax.position(x), ay.position(y));
            ASSERT_EQ(reach.contains(x, y), reads) << "mip " << mip << " sample " << x << "," << y;
          }
        }
      }
    }
  }
}

}  // namespace
}  // namespace loam::terrain
